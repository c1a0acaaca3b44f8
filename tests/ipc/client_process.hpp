// SPDX-License-Identifier: Apache-2.0
// A client program as a child process whose output the test reads as it runs (TEST_CLIENT_PATH
// by default: the includer defines it).
#pragma once

#include <fcntl.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "sim_process.hpp"

namespace drivebus::test {

// A test_client process (or `program`) whose stdout is read as it runs.
class Client {
public:
    explicit Client(const std::vector<std::string>& args, const char* program = TEST_CLIENT_PATH) {
        int fds[2];
        if (::pipe2(fds, O_CLOEXEC) != 0) {
            throw std::runtime_error("pipe");
        }
        pid_ = ::fork();
        if (pid_ == 0) {
            // A test killed by its time-out takes its children with it: a daemon left running would
            // hold the machine's RouDi and fail every test after it.
            ::prctl(PR_SET_PDEATHSIG, SIGTERM);
            ::dup2(fds[1], STDOUT_FILENO);
            ::dup2(fds[1], STDERR_FILENO);
            std::vector<char*> argv;
            std::vector<std::string> all = {program};
            all.insert(all.end(), args.begin(), args.end());
            for (auto& a : all) {
                argv.push_back(a.data());
            }
            argv.push_back(nullptr);
            ::execv(argv[0], argv.data());
            ::_exit(127);
        }
        ::close(fds[1]);
        fd_ = fds[0];
        ::fcntl(fd_, F_SETFL, O_NONBLOCK);
    }
    ~Client() {
        if (pid_ > 0) {
            ::kill(pid_, SIGKILL);
            ::waitpid(pid_, nullptr, 0);
        }
        ::close(fd_);
    }
    Client(const Client&) = delete;
    Client& operator=(const Client&) = delete;
    Client(Client&&) = delete;
    Client& operator=(Client&&) = delete;

    // Everything it has printed so far.
    const std::string& output() {
        char buf[4096];
        ssize_t n = 0;
        while ((n = ::read(fd_, buf, sizeof buf)) > 0) {
            out_.append(buf, static_cast<std::size_t>(n));
        }
        return out_;
    }
    bool printed(const std::string& text, std::chrono::milliseconds timeout) {
        return wait_until([&] { return output().find(text) != std::string::npos; }, timeout);
    }
    // Waits for it to end; its exit status, or -1 on timeout.
    int wait(std::chrono::milliseconds timeout) {
        if (pid_ <= 0) {
            return -1;
        }
        int status = 0;
        const bool done = wait_until([&] { return ::waitpid(pid_, &status, WNOHANG) == pid_; }, timeout);
        if (!done) {
            output();
            out_ += "[still running after the wait: " + threads() + "]\n";
            return -1;
        }
        pid_ = -1;
        output();
        return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    }
    // Idempotent: once it has ended, pid_ is -1, and kill(-1) would signal every process.
    void kill9() {
        if (pid_ <= 0) {
            return;
        }
        ::kill(pid_, SIGKILL);
        ::waitpid(pid_, nullptr, 0);
        pid_ = -1;
    }

    // Where each of its threads waits (name, kernel wait channel, state): what a hung client
    // was doing, for the failure message.
    [[nodiscard]] std::string threads() const { return threads_of(pid_); }

    // The same of any process (drivebusd: where its embedded RouDi's threads wait).
    [[nodiscard]] static std::string threads_of(int pid) {
        std::string out;
        const std::filesystem::path tasks = "/proc/" + std::to_string(pid) + "/task";
        std::error_code ec;
        for (const auto& task : std::filesystem::directory_iterator(tasks, ec)) {
            const auto read = [&](const char* name) {
                std::ifstream in(task.path() / name);
                std::string text;
                for (std::string line; std::getline(in, line);) {
                    text += (text.empty() ? "" : "\n") + line;
                }
                return text;
            };
            const std::string status = read("status");
            const auto state = status.find("State:");
            out += task.path().filename().string() + " " + read("comm") + " wchan=" + read("wchan") + " " +
                   (state == std::string::npos ? "" : status.substr(state + 7, status.find('\n', state) - state - 7)) +
                   futex_of(pid, read("syscall")) + "; ";
        }
        return out;
    }

    // A thread in futex(2): the word it waits on, the mapping that holds it, and the three ints
    // from there (a pthread mutex: lock word, count, owner's thread id), so that a hang names
    // the lock and who holds it. Empty for any other system call.
    [[nodiscard]] static std::string futex_of(int pid, const std::string& syscall) {
        std::istringstream in(syscall);
        std::string number;
        std::string first;
        in >> number >> first;
        if (number != "202" || first.rfind("0x", 0) != 0) {  // futex on x86-64
            return {};
        }
        const auto address = std::stoull(first, nullptr, 16);
        std::string where = "?";
        std::ifstream maps("/proc/" + std::to_string(pid) + "/maps");
        for (std::string line; std::getline(maps, line);) {
            unsigned long long from = 0;
            unsigned long long to = 0;
            char dash = 0;
            std::istringstream l(line);
            l >> std::hex >> from >> dash >> to;
            if (address >= from && address < to) {
                const auto path = line.find('/');
                where = path == std::string::npos ? "anonymous" : line.substr(path);
                break;
            }
        }
        std::array<int, 3> words{};
        std::ifstream mem("/proc/" + std::to_string(pid) + "/mem", std::ios::binary);
        mem.seekg(static_cast<std::streamoff>(address));
        const bool read = static_cast<bool>(mem.read(reinterpret_cast<char*>(words.data()), sizeof words));
        return " futex=" + first + " in " + where +
               (read ? " [" + std::to_string(words[0]) + " " + std::to_string(words[1]) + " " +
                           std::to_string(words[2]) + "]"
                     : std::string(" [unreadable]"));
    }

private:
    int pid_ = -1;
    int fd_ = -1;
    std::string out_;
};

inline std::vector<std::string> lines_with(const std::string& text, const std::string& prefix) {
    std::vector<std::string> out;
    std::istringstream in(text);
    for (std::string line; std::getline(in, line);) {
        if (line.rfind(prefix, 0) == 0) {
            out.push_back(line);
        }
    }
    return out;
}

}  // namespace drivebus::test
