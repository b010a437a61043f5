// Digests of released artefacts (docs/commissioning.md, "Release"): a
// released part program names the SHA-256 of the verification report that
// proved it, so the report it was released on can be told from any other.
#pragma once

#include <filesystem>
#include <string>
#include <string_view>

namespace hg {

/// SHA-256 of `bytes` as 64 lower-case hex digits (OpenSSL's EVP digest).
std::string sha256Hex(std::string_view bytes);

/// SHA-256 of a file's bytes; throws InputError naming the file when it cannot be read.
std::string sha256OfFile(const std::filesystem::path& file);

} // namespace hg
