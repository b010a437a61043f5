#include "hullgauge/common/durable_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <string>

#include "hullgauge/common/error.h"

namespace hg {
namespace {

[[noreturn]] void fail(const std::filesystem::path& path, const char* what, int err)
{
    throw FaultError(path.string() + ": " + what + ": " + std::strerror(err));
}

void syncAndClose(int fd, const std::filesystem::path& path)
{
    const int synced = ::fsync(fd);
    const int err = errno;
    if (::close(fd) != 0 || synced != 0) fail(path, "cannot flush to disk", synced != 0 ? err : errno);
}

} // namespace

void writeFileDurably(const std::filesystem::path& file, std::string_view bytes)
{
    const int fd = ::open(file.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    if (fd < 0) fail(file, "cannot create", errno);
    while (!bytes.empty()) {
        const ssize_t n = ::write(fd, bytes.data(), bytes.size());
        if (n < 0 && errno == EINTR) continue;
        if (n < 0) {
            const int err = errno;
            ::close(fd);
            fail(file, "write failed", err);
        }
        bytes.remove_prefix(static_cast<std::size_t>(n));
    }
    syncAndClose(fd, file);
}

void syncFolder(const std::filesystem::path& folder)
{
    const int fd = ::open(folder.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (fd < 0) fail(folder, "cannot open", errno);
    syncAndClose(fd, folder);
}

void replaceFileDurably(const std::filesystem::path& file, std::string_view bytes)
{
    // Hidden and named by the process, so two writers never share one and a
    // listing of the folder does not show it as a result.
    auto folder = file.parent_path();
    if (folder.empty()) folder = ".";
    const auto tmp = folder / ("." + file.filename().string() + ".tmp-" + std::to_string(::getpid()));
    std::error_code ec;
    try {
        writeFileDurably(tmp, bytes);
    } catch (...) {
        std::filesystem::remove(tmp, ec);
        throw;
    }
    std::filesystem::rename(tmp, file, ec);
    if (ec) {
        const auto why = ec.message();
        std::filesystem::remove(tmp, ec);
        throw FaultError(file.string() + ": cannot replace it: " + why);
    }
    syncFolder(folder);
}

} // namespace hg

namespace hg {

void giveToFolderOwner(const std::filesystem::path& file)
{
    if (::geteuid() != 0) return;
    const auto folder = file.has_parent_path() ? file.parent_path() : std::filesystem::path(".");
    struct stat st {};
    if (::stat(folder.c_str(), &st) != 0) throw FaultError(folder.string() + ": " + std::strerror(errno));
    if (::chown(file.c_str(), st.st_uid, st.st_gid) != 0)
        throw FaultError("chown " + file.string() + ": " + std::strerror(errno));
}

} // namespace hg
