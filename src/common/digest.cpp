#include "hullgauge/common/digest.h"

#include "hullgauge/common/error.h"

#include <array>
#include <fstream>
#include <iterator>
#include <openssl/evp.h>

namespace hg {

std::string sha256Hex(std::string_view bytes)
{
    std::array<unsigned char, EVP_MAX_MD_SIZE> digest{};
    unsigned int length = 0;
    // Any bytes have a digest: a failure is the library's, a fault (docs/style.md point 4).
    if (EVP_Digest(bytes.data(), bytes.size(), digest.data(), &length, EVP_sha256(), nullptr) != 1)
        throw FaultError("OpenSSL's SHA-256 failed on " + std::to_string(bytes.size()) + " bytes");
    static constexpr char kHex[] = "0123456789abcdef";
    std::string hex;
    for (unsigned int i = 0; i < length; ++i) {
        hex += kHex[digest[i] >> 4];
        hex += kHex[digest[i] & 0xF];
    }
    return hex;
}

std::string sha256OfFile(const std::filesystem::path& file)
{
    std::ifstream in(file, std::ios::binary);
    if (!in) throw InputError(file.string(), "", "cannot be read");
    const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    return sha256Hex(bytes);
}

} // namespace hg
