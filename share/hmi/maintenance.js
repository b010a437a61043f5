// The line engineer's page (docs/hmi.md, "Maintenance"): calibration status,
// the part programs and their view plans for everyone; the state-changing
// actions only in a signed-in session, each carrying its CSRF token.
"use strict";
hg.nav("/maintenance");

let csrf = null;

function say(id, text) { document.getElementById(id).textContent = text; }

async function session() {
  const s = await hg.get("/api/session");
  csrf = s.csrf || null;
  document.getElementById("login").hidden = !s.configured || s.signed_in;
  document.getElementById("actions").hidden = !s.signed_in;
  say("session", !s.configured ? "Maintenance over HTTP is not configured on this station."
    : s.signed_in ? "Signed in." : "Read-only: sign in for maintenance actions.");
}

async function act(body) {
  try {
    const answer = await hg.post("/api/maintenance", body, csrf);
    say("action-result", JSON.stringify(answer));
  } catch (e) {
    say("action-result", "Refused: " + e.message);
  }
}

async function show() {
  try {
    const c = await hg.get("/api/calibration");
    say("calibration", JSON.stringify(c.calibration, null, 2));
    const p = await hg.get("/api/programs");
    const tbody = document.querySelector("#programs tbody");
    for (const prog of p.programs)
      tbody.append(hg.el("tr", {}, hg.el("td", { text: String(prog.number) }), hg.el("td", { text: prog.part }),
        hg.el("td", { text: prog.views_file }), hg.el("td", { class: "num", text: String(prog.views.length) }),
        hg.el("td", { text: prog.force ? "yes" : "no" })));
    await session();
  } catch (e) {
    say("error", e.message);
  }
}

document.getElementById("login").addEventListener("submit", async (ev) => {
  ev.preventDefault();
  try {
    const answer = await hg.post("/api/login", { password: document.getElementById("password").value });
    csrf = answer.csrf;
    document.getElementById("password").value = "";
    await session();
  } catch (e) {
    say("session", "Sign-in refused: " + e.message);
  }
});
document.getElementById("set-purpose").addEventListener("click", () => act({ command: "purpose", purpose: document.getElementById("purpose").value }));
document.getElementById("trigger").addEventListener("click", () => act({ command: "trigger",
  program: Number(document.getElementById("trigger-program").value), serial: document.getElementById("trigger-serial").value }));
document.getElementById("abort").addEventListener("click", () => act({ command: "abort" }));
document.getElementById("logout").addEventListener("click", async () => { await hg.post("/api/logout", {}, csrf); await session(); });
show();
