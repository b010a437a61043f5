// The accounts (docs/audit.md, "Accounts"): everyone with an account changes
// their own password; an administrator adds accounts, sets their role or a new
// password and removes them. The server checks every request; this page only
// leaves out what the role may not do.
"use strict";
hg.nav("/users");

const $ = (id) => document.getElementById(id);
let csrf = null;
const roles = ["operator", "engineer", "administrator"];

function say(text) { $("result").textContent = text; $("error").textContent = ""; }
function fail(e) { $("error").textContent = "Refused: " + e.message; }

async function change(path, body, done) {
  try {
    await hg.post(path, body, csrf);
    say(done);
    await accounts();
  } catch (e) { fail(e); }
}

function accountRow(u) {
  const role = hg.el("select", { "data-name": u.name, class: "role" });
  for (const r of roles) {
    const o = hg.el("option", { text: r });
    if (r === u.role) o.selected = true;
    role.append(o);
  }
  role.addEventListener("change", () => change(`/api/users/${u.name}`, { role: role.value }, `${u.name} is now ${role.value}.`));
  const password = hg.el("input", { type: "password", minlength: "8", autocomplete: "new-password", "data-name": u.name });
  const set = hg.el("button", { text: "Set" });
  set.addEventListener("click", () => change(`/api/users/${u.name}`, { password: password.value }, `New password for ${u.name}.`));
  const remove = hg.el("button", { text: "Remove", class: "remove" });
  remove.addEventListener("click", () => {
    if (confirm(`Remove the account ${u.name}?`)) change(`/api/users/${u.name}/remove`, {}, `${u.name} removed.`);
  });
  return hg.el("tr", { "data-name": u.name }, hg.el("td", { text: u.name }), hg.el("td", {}, role),
    hg.el("td", {}, password, set), hg.el("td", {}, remove));
}

async function accounts() {
  const list = await hg.get("/api/users");
  const tbody = document.querySelector("#accounts tbody");
  tbody.replaceChildren(...list.users.map(accountRow));
}

async function session() {
  const s = await hg.get("/api/session");
  csrf = s.csrf || null;
  $("sign-in-card").hidden = s.signed_in;
  $("own-card").hidden = !s.signed_in || s.shared;
  const admin = s.signed_in && s.may.users;
  $("add-card").hidden = !admin;
  $("accounts-card").hidden = !admin;
  $("session").textContent = !s.signed_in ? "Sign in with your account." : "Signed in as " + hg.who(s) + "." +
    (admin ? "" : " Only an administrator manages the accounts.");
  if (admin) await accounts();
}

$("login").addEventListener("submit", async (ev) => {
  ev.preventDefault();
  try {
    await hg.signIn($("login-name").value.trim(), $("login-password").value);
    $("login-password").value = "";
    await session();
  } catch (e) { $("error").textContent = "Sign-in refused: " + e.message; }
});
$("add").addEventListener("submit", (ev) => {
  ev.preventDefault();
  const name = $("add-name").value.trim();
  change("/api/users", { name, role: $("add-role").value, password: $("add-password").value }, `${name} added.`)
    .then(() => { $("add-password").value = ""; $("add-name").value = ""; });
});
$("own").addEventListener("submit", (ev) => {
  ev.preventDefault();
  change("/api/account/password", { current: $("own-current").value, password: $("own-new").value }, "Your password is changed.")
    .then(() => { $("own-current").value = ""; $("own-new").value = ""; });
});
$("logout").addEventListener("click", async () => { await hg.post("/api/logout", {}, csrf); await session(); });
session().catch((e) => { $("error").textContent = e.message; });
