// A password's hash as an administrator's tool would write it (docs/audit.md,
// "Accounts"): crypt(3) SHA-512 with a fixed salt, made by libcrypt and not by
// the code under test, so the tests' passwords are judged independently.
#pragma once

#include <crypt.h>
#include <string>

namespace hgtest {

inline std::string sha512CryptOf(const std::string& password, const std::string& salt = "hullgaugetest")
{
    crypt_data data{};
    return crypt_r(password.c_str(), ("$6$" + salt + "$").c_str(), &data);
}

} // namespace hgtest
