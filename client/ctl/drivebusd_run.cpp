// SPDX-License-Identifier: Apache-2.0
#include "drivebusd_run.hpp"

#include <fcntl.h>
#include <spawn.h>
#include <sys/mman.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>

namespace drivebus::ctl {
namespace {

// A file in memory for one of drivebusd's streams: no pipe to drain while it runs.
class MemoryFile {
public:
    explicit MemoryFile(const char* name) : fd_(::memfd_create(name, MFD_CLOEXEC)) {}
    MemoryFile(const MemoryFile&) = delete;
    MemoryFile& operator=(const MemoryFile&) = delete;
    ~MemoryFile() {
        if (fd_ >= 0) {
            ::close(fd_);
        }
    }
    [[nodiscard]] int fd() const noexcept { return fd_; }

    // Everything written to it, from the start.
    [[nodiscard]] std::string text() const {
        std::string out;
        char buffer[4096];
        off_t at = 0;
        for (;;) {
            const auto n = ::pread(fd_, buffer, sizeof buffer, at);
            if (n < 0 && errno == EINTR) {
                continue;
            }
            if (n <= 0) {
                return out;
            }
            out.append(buffer, static_cast<std::size_t>(n));
            at += n;
        }
    }

private:
    int fd_;
};

std::string failed(const std::string& program, int error) {
    return "cannot run " + program + ": " + std::strerror(error);
}

}  // namespace

std::string drivebusd_program() {
    const char* named = std::getenv("DRIVEBUSD");
    return named != nullptr && *named != '\0' ? named : DRIVEBUSD_INSTALLED;
}

std::expected<DrivebusdRun, std::string> run_drivebusd(const std::vector<std::string>& args) {
    const auto program = drivebusd_program();
    const MemoryFile out("drivebusd-stdout");
    const MemoryFile err("drivebusd-stderr");
    if (out.fd() < 0 || err.fd() < 0) {
        return std::unexpected(failed(program, errno));
    }
    std::vector<std::string> owned = {program};
    owned.insert(owned.end(), args.begin(), args.end());
    std::vector<char*> argv;
    for (auto& arg : owned) {
        argv.push_back(arg.data());
    }
    argv.push_back(nullptr);

    posix_spawn_file_actions_t actions;
    ::posix_spawn_file_actions_init(&actions);
    ::posix_spawn_file_actions_addopen(&actions, STDIN_FILENO, "/dev/null", O_RDONLY, 0);
    ::posix_spawn_file_actions_adddup2(&actions, out.fd(), STDOUT_FILENO);
    ::posix_spawn_file_actions_adddup2(&actions, err.fd(), STDERR_FILENO);
    pid_t pid = 0;
    const int spawned = ::posix_spawn(&pid, program.c_str(), &actions, nullptr, argv.data(), environ);
    ::posix_spawn_file_actions_destroy(&actions);
    if (spawned != 0) {
        return std::unexpected(failed(program, spawned));
    }
    int status = 0;
    while (::waitpid(pid, &status, 0) < 0) {
        if (errno != EINTR) {
            return std::unexpected(failed(program, errno));
        }
    }
    DrivebusdRun run;
    run.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    run.out = out.text();
    run.err = err.text();
    return run;
}

}  // namespace drivebus::ctl
