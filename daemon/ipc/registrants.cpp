// SPDX-License-Identifier: Apache-2.0
#include "ipc/registrants.hpp"

#include <unistd.h>

#include <algorithm>
#include <charconv>
#include <ctime>
#include <fstream>
#include <sstream>
#include <string_view>
#include <utility>
#include <vector>

#include <fmt/format.h>

namespace drivebus::ipc {
namespace {

// What /proc/PID/status and /proc/PID/stat say of one process.
struct Facts {
    std::vector<pid_t> nspid;  // its pid in each PID namespace from /proc's down to its own
    std::vector<uid_t> uids;   // real, effective, saved, filesystem
    std::uint64_t start_ticks = 0;
};

template <typename T>
std::vector<T> numbers(std::string_view text) {
    std::vector<T> out;
    std::istringstream in{std::string(text)};
    for (long long n = 0; in >> n;) {
        out.push_back(static_cast<T>(n));
    }
    return out;
}

std::optional<Facts> facts_of(const std::filesystem::path& dir) {
    std::ifstream status(dir / "status");
    if (!status) {
        return std::nullopt;
    }
    Facts facts;
    for (std::string line; std::getline(status, line);) {
        const std::string_view view = line;
        if (view.starts_with("NSpid:")) {
            facts.nspid = numbers<pid_t>(view.substr(6));
        } else if (view.starts_with("Uid:")) {
            facts.uids = numbers<uid_t>(view.substr(4));
        }
    }
    std::ifstream stat(dir / "stat");
    std::string text;
    if (!std::getline(stat, text)) {
        return std::nullopt;
    }
    // The fields after the name (which may hold spaces and parentheses): state is field 3, the
    // start time field 22.
    const auto paren = text.rfind(')');
    if (paren == std::string::npos) {
        return std::nullopt;
    }
    std::istringstream fields(text.substr(paren + 1));
    std::string field;
    for (int i = 3; i <= 22 && fields >> field; ++i) {
        if (i == 22) {
            const auto* end = field.data() + field.size();
            if (std::from_chars(field.data(), end, facts.start_ticks).ptr != end) {
                return std::nullopt;
            }
            return facts;
        }
    }
    return std::nullopt;
}

bool is_pid(const std::string& name) {
    return !name.empty() && name.find_first_not_of("0123456789") == std::string::npos;
}

}  // namespace

std::optional<std::string> judge_registrant(pid_t pid, uid_t uid, std::uint64_t registered_ticks,
                                            const std::filesystem::path& proc, bool sees_all) {
    if (!sees_all) {
        return std::string(
            "drivebusd's /proc hides other users' processes (hidepid, systemd's ProtectProc=), so "
            "it cannot tell which process that pid is");
    }
    const auto self = facts_of(proc / "self");
    if (!self || self->nspid.empty()) {
        return std::string("this kernel's /proc does not say which PID namespace a process is in (no NSpid)");
    }
    const std::size_t depth = self->nspid.size();
    const auto facts = pid > 0 ? facts_of(proc / std::to_string(pid)) : std::nullopt;
    if (!facts) {
        return fmt::format("there is no process {} in drivebusd's PID namespace (a container's, or it ended)", pid);
    }
    if (facts->nspid.size() != depth) {
        return fmt::format("process {} here is in another PID namespace", pid);
    }
    if (std::ranges::find(facts->uids, uid) == facts->uids.end()) {
        return fmt::format("process {} here is not of user {}, which the runtime gave (a container's runtime?)", pid,
                           uid);
    }
    if (facts->start_ticks > registered_ticks) {
        return fmt::format("process {} here started after the runtime registered (the pid was used again)", pid);
    }
    // A process in a PID namespace below drivebusd's that numbers itself `pid` could be the one
    // that registered: the pid says nothing then.
    std::error_code ec;
    for (const auto& entry : std::filesystem::directory_iterator(proc, ec)) {
        const auto name = entry.path().filename().string();
        if (!is_pid(name) || name == std::to_string(pid)) {
            continue;
        }
        const auto other = facts_of(entry.path());
        if (other && other->nspid.size() > depth && other->nspid.back() == pid) {
            return fmt::format(
                "process {} here has pid {} in a PID namespace below drivebusd's, so the pid is "
                "ambiguous",
                name, pid);
        }
    }
    if (ec) {
        return fmt::format("cannot list {}: {}", proc.string(), ec.message());
    }
    return std::nullopt;
}

bool proc_shows_everyone() {
    if (::geteuid() == 0) {
        return true;
    }
    std::ifstream mounts("/proc/self/mountinfo");
    for (std::string line; std::getline(mounts, line);) {
        // ID PARENT MAJ:MIN ROOT MOUNTPOINT OPTIONS [OPTIONAL...] - FSTYPE SOURCE SUPEROPTIONS
        std::istringstream in(line);
        std::string id, parent, dev, root, point;
        in >> id >> parent >> dev >> root >> point;
        const auto dash = line.find(" - ");
        if (point != "/proc" || dash == std::string::npos) {
            continue;
        }
        std::istringstream tail(line.substr(dash + 3));
        std::string type, source, options;
        tail >> type >> source >> options;
        if (type != "proc") {
            continue;
        }
        const auto at = options.find("hidepid=");
        if (at == std::string::npos) {
            return true;
        }
        const auto value = options.substr(at + 8, options.find(',', at) - at - 8);
        return value == "0" || value == "off";
    }
    return true;
}

std::uint64_t boot_ticks_now() {
    timespec now{};
    ::clock_gettime(CLOCK_BOOTTIME, &now);
    const auto hz = static_cast<std::uint64_t>(::sysconf(_SC_CLK_TCK));
    return static_cast<std::uint64_t>(now.tv_sec) * hz + static_cast<std::uint64_t>(now.tv_nsec) * hz / 1'000'000'000U;
}

void Registrants::registered(const std::string& runtime, pid_t pid, std::optional<std::string> why_not_placed,
                             Clock::time_point now) {
    const std::lock_guard lock(mutex_);
    entries_[runtime] = Entry{.pid = pid, .why_not_placed = std::move(why_not_placed), .heard = now};
    latest_ = std::max(latest_, now);
}

void Registrants::heard(const std::string& runtime, Clock::time_point now) {
    const std::lock_guard lock(mutex_);
    if (const auto it = entries_.find(runtime); it != entries_.end()) {
        it->second.heard = now;
    }
    latest_ = std::max(latest_, now);
}

void Registrants::left(const std::string& runtime) {
    const std::lock_guard lock(mutex_);
    entries_.erase(runtime);
}

std::optional<Refusal> Registrants::refusal() {
    const std::lock_guard lock(mutex_);
    // Gone for RouDi: quiet for `silence` while others' messages still came. When RouDi's
    // message thread is held up, nobody is heard, and nobody is taken for gone.
    std::erase_if(entries_, [&](const auto& e) { return latest_ - e.second.heard > silence_; });
    for (const auto& [name, entry] : entries_) {
        if (entry.why_not_placed) {
            return Refusal{name, entry.pid, *entry.why_not_placed};
        }
    }
    return std::nullopt;
}

std::size_t Registrants::size() const {
    const std::lock_guard lock(mutex_);
    return entries_.size();
}

}  // namespace drivebus::ipc
