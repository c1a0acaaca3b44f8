// SPDX-License-Identifier: Apache-2.0
#include "suite_tools.hpp"

#include <fcntl.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fmt/format.h>
#include <algorithm>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <thread>
#include <utility>

#include "sim_process.hpp"

namespace drivebus::bench {

using namespace std::chrono_literals;

std::int64_t now_ns() {
    return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch())
        .count();
}

void note(const std::string& text) {
    std::fprintf(stderr, "bench: %s\n", text.c_str());
}

// Another RouDi (another drivebusd, a test run) must be gone before ours starts.
void wait_for_no_roudi() {
    bool told = false;
    const auto give_up = std::chrono::steady_clock::now() + 30min;
    while (roudi_answers()) {
        if (!told) {
            note("a RouDi answers on /tmp/roudi: waiting until it stops");
            told = true;
        }
        if (std::chrono::steady_clock::now() > give_up) {
            throw Failure("a RouDi kept answering on /tmp/roudi for 30 minutes");
        }
        std::this_thread::sleep_for(1s);
    }
}

std::string slurp(const fs::path& path) {
    std::ifstream in(path);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
}

// The scratch folders of this run, removed when it ends (DRIVEBUS_BENCH_KEEP=1 keeps them, with
// the programs' logs, to look into a failure).
struct Scratch {
    std::vector<fs::path> dirs;
    Scratch() = default;
    Scratch(const Scratch&) = delete;
    Scratch& operator=(const Scratch&) = delete;
    Scratch(Scratch&&) = delete;
    Scratch& operator=(Scratch&&) = delete;
    ~Scratch() {
        if (std::getenv("DRIVEBUS_BENCH_KEEP") != nullptr) {
            return;
        }
        for (const auto& dir : dirs) {
            std::error_code ec;
            fs::remove_all(dir, ec);
        }
    }
};

fs::path fresh_dir(const std::string& what) {
    static int counter = 0;
    static Scratch scratch;
    const fs::path dir =
        fs::temp_directory_path() / fmt::format("drivebus-bench-{}-{}-{}", ::getpid(), counter++, what);
    fs::remove_all(dir);
    fs::create_directories(dir);
    scratch.dirs.push_back(dir);
    return dir;
}

int spawn(const std::vector<std::string>& argv, const fs::path& out) {
    (void)test::own_state_dir();  // a drivebusd started here keeps its lease record there
    const int pid = ::fork();
    if (pid == 0) {
        const int o = ::open(out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
        const int e = ::open((out.string() + ".err").c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
        ::dup2(o, STDOUT_FILENO);
        ::dup2(e, STDERR_FILENO);
        std::vector<char*> args;
        for (const auto& a : argv) {
            args.push_back(const_cast<char*>(a.c_str()));
        }
        args.push_back(nullptr);
        ::execv(args[0], args.data());
        ::_exit(127);
    }
    return pid;
}

int wait_exit(int pid, std::chrono::seconds timeout) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    for (;;) {
        int status = 0;
        if (::waitpid(pid, &status, WNOHANG) == pid) {
            return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
        }
        if (std::chrono::steady_clock::now() > deadline) {
            ::kill(pid, SIGKILL);
            ::waitpid(pid, &status, 0);
            return -1;
        }
        std::this_thread::sleep_for(5ms);
    }
}

std::vector<std::vector<std::int64_t>> numbers(const std::string& text) {
    std::vector<std::vector<std::int64_t>> rows;
    std::istringstream in(text);
    std::string line;
    while (std::getline(in, line)) {
        std::istringstream l(line);
        std::vector<std::int64_t> row;
        long long v = 0;
        while (l >> v) {
            row.push_back(v);
        }
        if (!row.empty()) {
            rows.push_back(std::move(row));
        }
    }
    return rows;
}

std::vector<Event> read_events(const fs::path& path) {
    std::vector<Event> events;
    for (const auto& row : numbers(slurp(path))) {
        if (row.size() == 3) {
            events.push_back({row[0], static_cast<int>(row[1]), static_cast<int>(row[2])});
        }
    }
    std::ranges::sort(events, {}, &Event::ns);
    return events;
}

double us(std::int64_t ns) {
    return static_cast<double>(ns) / 1000.0;
}

Row samples_row(std::string item, std::string what, const std::vector<double>& samples, std::string notes) {
    Row r{std::move(item), std::move(what)};
    r.samples = samples.size();
    r.summary = summarize(samples);
    r.notes = std::move(notes);
    return r;
}

std::string field(const std::string& summary, const std::string& key) {
    const auto at = summary.find(key + "=");
    if (at == std::string::npos) {
        return "0";
    }
    const auto end = summary.find(' ', at);
    return summary.substr(at + key.size() + 1,
                          end == std::string::npos ? std::string::npos : end - at - key.size() - 1);
}

std::string cell(double v) {
    if (v >= 10000) {
        return fmt::format("{:.0f}", v);
    }
    if (v >= 100) {
        return fmt::format("{:.0f}", v);
    }
    return fmt::format("{:.1f}", v);
}

std::string table(const std::vector<Row>& rows) {
    std::string out =
        "| # | measurement | samples | p50 µs | p99 µs | p99.9 µs | max µs | notes | target | met |\n"
        "|---|---|---|---|---|---|---|---|---|---|\n";
    for (const auto& r : rows) {
        std::string p = "| – | – | – | – ";
        if (r.summary) {
            p = fmt::format("| {} | {} | {} | {} ", cell(r.summary->p50), cell(r.summary->p99), cell(r.summary->p999),
                            cell(r.summary->max));
        }
        out += fmt::format("| {} | {} | {} {}| {} | {} | {} |\n", r.item, r.what, r.samples, p, r.notes,
                           r.target.empty() ? "–" : r.target, !r.met ? "–" : (*r.met ? "yes" : "**no**"));
    }
    return out;
}

}  // namespace drivebus::bench
