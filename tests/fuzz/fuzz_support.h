// Shared by the libFuzzer harnesses (docs/fuzzing.md): the errors a parser
// documents are fine, anything else (a crash, a sanitizer report, another
// exception escaping, a hang) is a finding. Loaders that only take a path get
// the input written to a file in the harness's own temporary folder.
#pragma once

#include "hullgauge/common/error.h"
#include "hullgauge/common/log.h"

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <unistd.h>

namespace hg::fuzz {

/// One folder per harness process, removed at exit; the parsers' warnings are
/// silenced (a warning per input would cost more than the parsing).
inline const std::filesystem::path& workFolder()
{
    static const std::filesystem::path folder = [] {
        hg::log::configure("off");
        const char* tmp = std::getenv("TMPDIR");
        auto dir = std::filesystem::path(tmp && *tmp ? tmp : "/tmp") /
                   ("hullgauge-fuzz-" + std::to_string(static_cast<long>(getpid())));
        std::filesystem::create_directories(dir);
        static struct Remove {
            std::filesystem::path dir;
            ~Remove()
            {
                std::error_code ec;
                std::filesystem::remove_all(dir, ec);
            }
        } remove{dir};
        return dir;
    }();
    return folder;
}

inline std::filesystem::path writeInput(const std::string& name, const std::uint8_t* data, std::size_t size)
{
    const auto file = workFolder() / name;
    std::ofstream out(file, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
    return file;
}

/// Runs `parse`; the documented errors (docs/style.md point 4) end the input quietly.
template <class Parse> void expectDocumentedErrors(Parse&& parse)
{
    try {
        parse();
    } catch (const hg::InputError&) {
    } catch (const hg::FaultError&) {
    }
}

} // namespace hg::fuzz
