#include "hgtest/paths.h"

#include <cstdlib>
#include <fstream>
#include <random>
#include <sstream>
#include <stdexcept>
#include <sys/wait.h>

namespace hgtest {
namespace fs = std::filesystem;

namespace {
fs::path envPath(const char* name, const fs::path& fallback)
{
    const char* v = std::getenv(name);
    return v ? fs::path(v) : fallback;
}

std::string slurp(const fs::path& p)
{
    std::ifstream in(p, std::ios::binary);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
}
} // namespace

fs::path sourceDir()
{
    return envPath("HULLGAUGE_SOURCE_DIR", fs::current_path());
}
fs::path binaryDir()
{
    return envPath("HULLGAUGE_BINARY_DIR", fs::current_path());
}

TempDir::TempDir()
{
    std::random_device rd;
    for (int attempt = 0; attempt < 100; ++attempt) {
        auto p = fs::temp_directory_path() / ("hullgauge-test-" + std::to_string(rd()));
        if (fs::create_directory(p)) {
            path_ = p;
            return;
        }
    }
    throw std::runtime_error("cannot create a temporary folder");
}

TempDir::~TempDir()
{
    std::error_code ec;
    fs::remove_all(path_, ec);
}

fs::path writeFile(const fs::path& path, const std::string& text)
{
    if (path.has_parent_path()) fs::create_directories(path.parent_path());
    std::ofstream out(path, std::ios::binary);
    out << text;
    if (!out) throw std::runtime_error("cannot write " + path.string());
    return path;
}

RunResult run(const std::string& command)
{
    TempDir tmp;
    auto outPath = tmp / "stdout";
    auto errPath = tmp / "stderr";
    std::string full = command + " >" + outPath.string() + " 2>" + errPath.string();
    int raw = std::system(full.c_str());
    RunResult r;
    r.status = WIFEXITED(raw) ? WEXITSTATUS(raw) : -1;
    r.out = slurp(outPath);
    r.err = slurp(errPath);
    return r;
}

} // namespace hgtest
