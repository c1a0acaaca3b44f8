// SPDX-License-Identifier: Apache-2.0
#include "view.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <ctime>

#include "format.hpp"
#include "view_parts.hpp"

namespace drivebus::ctl {
namespace {

using detail::info_of;
using detail::join;
using detail::line_text;
using detail::ms_text;
using detail::ms_value;

std::string hz_text(const DriveState& st, const Profile& profile) {
    int places = 2;
    if (profile.control) {
        if (const auto* r = profile.find(profile.control->output_frequency)) {
            places = decimals(r->scale);
        }
    }
    return fmt::format("{:.{}f} Hz", *st.output_hz, places);
}

std::string fault_text(const DriveState& st) {
    if (!st.fault_code) {
        return st.fault ? "fault" : "";
    }
    if (*st.fault_code == 0) {
        return "no fault";
    }
    if (!st.fault_name.empty()) {
        return fmt::format("fault {} ({})", st.fault_name, st.fault_title);
    }
    return fmt::format("fault code {}", *st.fault_code);
}

std::string age_of(std::int64_t time_ns, std::int64_t now_ns) {
    return time_ns > 0 ? format_age(now_ns - time_ns) : std::string("-");
}

Json timing_json(const shm::Timing& t) {
    return Json::object().set("count", t.count).set("mean_ms", ms_value(t.mean_ns)).set("max_ms", ms_value(t.max_ns));
}

std::string timing_text(const shm::Timing& t, std::string_view what) {
    if (t.count == 0) {
        return "none yet";
    }
    return fmt::format("mean {}, max {} ({} {})", ms_text(t.mean_ns), ms_text(t.max_ns), t.count, what);
}

std::vector<std::pair<std::string, std::uint64_t>> bus_counters(const shm::BusCounters& c) {
    std::vector<std::pair<std::string, std::uint64_t>> named;
#define DRIVEBUS_NAME_COUNTER(name) named.emplace_back(#name, c.name);
    DRIVEBUS_SHM_BUS_COUNTERS(DRIVEBUS_NAME_COUNTER)
#undef DRIVEBUS_NAME_COUNTER
    return named;
}

std::vector<std::pair<std::string, std::uint64_t>> drive_counters(const shm::DriveCounters& c) {
    return {{"requests", c.requests},
            {"replies", c.replies},
            {"timeouts", c.timeouts},
            {"bad_frames", c.bad_frames},
            {"retries", c.retries},
            {"exceptions", c.exceptions},
            {"absent_transitions", c.absent_transitions},
            {"late", c.late}};
}

std::string counters_text(const std::vector<std::pair<std::string, std::uint64_t>>& counters) {
    std::vector<std::string> parts;
    for (const auto& [name, value] : counters) {
        auto label = name;
        std::ranges::replace(label, '_', ' ');
        parts.push_back(fmt::format("{} {}", label, value));
    }
    return join(parts, ", ");
}

Json counters_json(const std::vector<std::pair<std::string, std::uint64_t>>& counters) {
    auto out = Json::object();
    for (const auto& [name, value] : counters) {
        out.set(name, value);
    }
    return out;
}

// A time-out in a list: "3 s", "off", "1 s, may fire", "-" when not known.
std::string comm_timeout_cell(shm::CommTimeoutState state, shm::CommTimeoutVerdict verdict, std::uint32_t ms) {
    using State = shm::CommTimeoutState;
    if (state == State::Unknown) {
        return "-";
    }
    if (state == State::ReadRefused) {
        return "unreadable";
    }
    std::string out = ms == 0 ? std::string("off") : fmt::format("{:g} s", ms / 1000.0);
    if (verdict == shm::CommTimeoutVerdict::MayFire) {
        out += ", may fire";
    }
    if (state == State::WriteRefused || state == State::ReadBack) {
        out += ", not as configured";
    }
    return out;
}

// What a drive's snapshot says of its own Modbus time-out, in one phrase.
std::string comm_timeout_text(const shm::CommTimeout& c, const Profile* profile) {
    using State = shm::CommTimeoutState;
    const SafetyInfo* safety = profile != nullptr && profile->safety ? &*profile->safety : nullptr;
    const std::string reg = safety != nullptr ? safety->comm_timeout : std::string("time-out");
    const auto seconds = [](std::uint32_t ms) {
        return ms == 0 ? std::string("off") : fmt::format("{:g} s", ms / 1000.0);
    };
    const auto refusal = [&] { return c.exception != 0 ? fmt::format("exception {}", c.exception) : "no valid reply"; };
    std::string out;
    switch (c.state) {
    case State::Unknown: return safety != nullptr ? "not read yet" : "none named by the profile";
    case State::ReadRefused: return fmt::format("{} could not be read ({})", reg, refusal());
    case State::Read: out = fmt::format("{} = {}", reg, seconds(c.timeout_ms)); break;
    case State::Written: out = fmt::format("{} = {}, written as configured", reg, seconds(c.timeout_ms)); break;
    case State::WriteRefused:
        out = fmt::format("{} = {}; writing the configured {} was refused ({})", reg, seconds(c.timeout_ms),
                          seconds(c.wanted_ms), refusal());
        break;
    case State::ReadBack:
        out = fmt::format("{} = {}; written {}, it reads back otherwise", reg, seconds(c.timeout_ms),
                          seconds(c.wanted_ms));
        break;
    }
    if (c.action_valid != 0 && safety != nullptr) {
        const RegisterInfo* action = profile->find(std::string_view(safety->comm_fault_action));
        const auto meaning = action != nullptr ? value_meaning(*action, c.action) : std::string();
        out += fmt::format("; when it fires: {} = {}{}", safety->comm_fault_action, c.action,
                           meaning.empty() ? "" : " (" + meaning + ")");
    }
    const std::string gap = c.gap_ms == 0 ? std::string("nothing bounds the time between drivebusd's requests")
                                          : fmt::format("drivebusd's requests at most {:g} s apart", c.gap_ms / 1000.0);
    switch (c.verdict) {
    case shm::CommTimeoutVerdict::None: break;
    case shm::CommTimeoutVerdict::Fine: out += "; fine (" + gap + ")"; break;
    case shm::CommTimeoutVerdict::Off: out += "; OFF: if the line or drivebusd dies, the drive runs on"; break;
    case shm::CommTimeoutVerdict::MayFire: out += "; MAY FIRE on a healthy line (" + gap + ")"; break;
    }
    return out;
}

Json comm_timeout_json(const shm::CommTimeout& c, const Profile* profile) {
    const SafetyInfo* safety = profile != nullptr && profile->safety ? &*profile->safety : nullptr;
    const bool known = c.state != shm::CommTimeoutState::Unknown && c.state != shm::CommTimeoutState::ReadRefused;
    auto out = Json::object();
    out.set("register", safety != nullptr ? Json(safety->comm_timeout) : Json());
    out.set("state", shm::to_string(c.state)).set("verdict", shm::to_string(c.verdict));
    out.set("raw", known ? Json(c.raw) : Json()).set("timeout_ms", known ? Json(c.timeout_ms) : Json());
    out.set("wanted_ms", c.wanted_ms != 0 ? Json(c.wanted_ms) : Json());
    out.set("exception", c.exception != 0 ? Json(c.exception) : Json());
    out.set("gap_ms", c.gap_ms != 0 ? Json(c.gap_ms) : Json());
    out.set("fault_action_register", safety != nullptr ? Json(safety->comm_fault_action) : Json());
    out.set("fault_action", c.action_valid != 0 ? Json(c.action) : Json());
    return out;
}

}  // namespace

std::int64_t monotonic_ns() noexcept {
    timespec ts{};
    ::clock_gettime(CLOCK_MONOTONIC, &ts);
    return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

Json register_json(std::uint16_t address, std::uint16_t raw, const RegisterInfo* info) {
    auto out = Json::object();
    out.set("name", info != nullptr ? Json(info->name) : Json());
    out.set("address", address).set("hex", hex(address)).set("raw", raw);
    if (info != nullptr) {
        out.set("value", has_engineering(*info) ? Json(engineering(*info, raw)) : Json(raw));
        out.set("unit", info->unit).set("title", info->title);
        auto bits = Json::array();
        for (const auto& b : set_bits(*info, raw)) {
            bits.push(b);
        }
        out.set("bits", std::move(bits));
        if (const auto meaning = value_meaning(*info, raw); !meaning.empty()) {
            out.set("meaning", meaning);
        }
    }
    return out;
}

bool has_state(const Profile* profile) noexcept {
    return profile != nullptr && profile->control &&
           (!profile->control->status.empty() || !profile->control->output_frequency.empty());
}

std::string state_text(const DriveState& st, const Profile& profile) {
    std::vector<std::string> parts;
    if (st.status_word) {
        parts.push_back(st.running ? (st.reverse ? "running reverse" : "running forward") : "stopped");
    }
    if (st.output_hz) {
        parts.push_back(hz_text(st, profile));
    }
    if (const auto fault = fault_text(st); !fault.empty()) {
        parts.push_back(fault);
    }
    if (st.status_word || !st.alarms.empty()) {
        parts.push_back(st.alarms.empty() ? (st.alarm ? "alarm" : "no alarm") : "alarms: " + join(st.alarms, ", "));
    }
    return parts.empty() ? std::string("not polled") : join(parts, ", ");
}

Json state_json(const DriveState& st) {
    auto out = Json::object();
    out.set("status_word", st.status_word ? Json(*st.status_word) : Json());
    out.set("running", st.running).set("reverse", st.reverse).set("fault", st.fault).set("alarm", st.alarm);
    out.set("ready", st.ready);
    out.set("output_hz", st.output_hz ? Json(*st.output_hz) : Json());
    out.set("fault_code", st.fault_code ? Json(*st.fault_code) : Json());
    out.set("fault_name", st.fault_name).set("fault_title", st.fault_title);
    auto alarms = Json::array();
    for (const auto& a : st.alarms) {
        alarms.push(a);
    }
    out.set("alarms", std::move(alarms));
    auto flags = Json::array();
    for (const auto& f : st.flags) {
        flags.push(f);
    }
    out.set("flags", std::move(flags));
    return out;
}

// Who holds it, as that client names itself (libdrivebus: "application[pid]"); drivebusd
// publishes nothing that would let another client act under the lease.
std::string holder_text(const shm::LeaseStatus& lease) {
    return std::string(shm::view(lease.holder));
}

std::string lease_text(const shm::LeaseStatus& lease, std::int64_t now_ns) {
    std::string text;
    switch (lease.state) {
    case shm::LeaseState::Free: text = "free"; break;
    case shm::LeaseState::Held:
        text = fmt::format("held by {} (expires in {})", holder_text(lease), format_age(lease.expires_ns - now_ns));
        break;
    case shm::LeaseState::Expired:
        text = fmt::format("expired {} ago (holder {}), fallback {}", format_age(now_ns - lease.expired_ns),
                           holder_text(lease), lease.fallback_ok != 0 ? "applied" : "not acknowledged");
        break;
    }
    return fmt::format("{}; fallback {}, {} {}", text, shm::to_string(lease.fallback), lease.expiries,
                       lease.expiries == 1 ? "expiry" : "expiries");
}

Json lease_json(const shm::LeaseStatus& lease, std::int64_t now_ns) {
    auto out = Json::object();
    out.set("state", shm::to_string(lease.state));
    out.set("holder", lease.state == shm::LeaseState::Free ? Json() : Json(shm::view(lease.holder)));
    out.set("holder_pid", lease.state == shm::LeaseState::Free ? Json() : Json(lease.holder_pid));
    out.set("duration_ms", lease.duration_ms);
    out.set("expires_in_ms",
            lease.state == shm::LeaseState::Held ? Json((lease.expires_ns - now_ns) / 1'000'000) : Json());
    out.set("fallback", shm::to_string(lease.fallback)).set("fallback_ok", lease.fallback_ok != 0);
    out.set("expiries", lease.expiries);
    return out;
}

std::string drive_status_text(const shm::DriveSnapshot& s, const Profile* profile, std::int64_t now_ns) {
    std::vector<std::pair<std::string, std::string>> fields = {
        {"drive", fmt::format("{} (address {}, profile {}, bus {})", shm::view(s.name), s.address, shm::view(s.profile),
                              shm::view(s.bus))},
        {"health", std::string(shm::to_string(s.health))},
        {"snapshot", fmt::format("#{}, {} ago", s.sequence, format_age(now_ns - s.published_ns))},
    };
    if (has_state(profile)) {
        fields.emplace_back("state", state_text(decode_state(*profile, s), *profile));
    }
    fields.emplace_back("lease", lease_text(s.lease, now_ns));
    fields.emplace_back("time-out", comm_timeout_text(s.comm_timeout, profile));
    fields.emplace_back("counters", counters_text(drive_counters(s.counters)));
    std::string out = render_fields(fields);
    std::vector<Row> rows = {{"NAME", "ADDRESS", "RAW", "VALUE", "VALID", "AGE", "TITLE"}};
    for (std::size_t i = 0; i < s.register_count && i < s.registers.size(); ++i) {
        const auto& r = s.registers[i];
        auto columns = register_columns(r.address, r.value, info_of(profile, r.address));
        rows.push_back({columns[0], columns[1], columns[2], columns[3], r.valid != 0 ? "yes" : "no",
                        age_of(r.time_ns, now_ns), columns[4]});
    }
    out += "\n" + render_table(rows);
    return out;
}

Json drive_status_json(const shm::DriveSnapshot& s, const Profile* profile, std::int64_t now_ns) {
    auto out = Json::object();
    out.set("bus", shm::view(s.bus)).set("drive", shm::view(s.name)).set("address", s.address);
    out.set("profile", shm::view(s.profile)).set("health", shm::to_string(s.health));
    out.set("sequence", s.sequence).set("age_ms", (now_ns - s.published_ns) / 1'000'000);
    out.set("counters", counters_json(drive_counters(s.counters)));
    out.set("lease", lease_json(s.lease, now_ns));
    out.set("comm_timeout", comm_timeout_json(s.comm_timeout, profile));
    out.set("state", has_state(profile) ? state_json(decode_state(*profile, s)) : Json());
    auto registers = Json::array();
    for (std::size_t i = 0; i < s.register_count && i < s.registers.size(); ++i) {
        const auto& r = s.registers[i];
        auto item = register_json(r.address, r.value, info_of(profile, r.address));
        item.set("valid", r.valid != 0);
        item.set("age_ms", r.time_ns > 0 ? Json((now_ns - r.time_ns) / 1'000'000) : Json());
        registers.push(std::move(item));
    }
    out.set("registers", std::move(registers));
    return out;
}

std::string bus_status_text(const shm::BusStatus& s, bool can_request, std::int64_t now_ns) {
    const auto group = std::string(shm::view(s.control_group));
    const std::string requests = group.empty() ? std::string(can_request ? "open to every client" : "not possible")
                                 : can_request ? fmt::format("group {} (you are a member)", group)
                                               : fmt::format("group {} (you are not a member: watching only)", group);
    std::vector<std::pair<std::string, std::string>> fields = {
        {"bus", std::string(shm::view(s.bus))},
        {"device", line_text(s)},
        {"state", s.up != 0 ? "up" : "down"},
        {"drives", fmt::format("{} of {} online", s.drives_online, s.drive_count)},
        {"daemon", fmt::format("pid {}, last status {} ago", s.daemon_pid, format_age(now_ns - s.published_ns))},
        {"requests", requests},
        {"reply latency", timing_text(s.reply_latency, "replies")},
        {"extra gap", timing_text(s.extra_gap, "requests")},
    };
    std::string out = render_fields(fields);
    out += "\ncounters\n";
    std::vector<std::pair<std::string, std::string>> counters;
    for (const auto& [name, value] : bus_counters(s.counters)) {
        auto label = name;
        std::ranges::replace(label, '_', ' ');
        counters.emplace_back(label, std::to_string(value));
    }
    out += render_fields(counters, "  ");
    out += "\n" + render_table(drive_rows(s));
    return out;
}

Json bus_status_json(const shm::BusStatus& s, bool can_request, std::int64_t now_ns) {
    auto out = Json::object();
    out.set("bus", shm::view(s.bus)).set("device", shm::view(s.device)).set("baud", s.baud);
    out.set("format", shm::view(s.format)).set("up", s.up != 0).set("daemon_pid", s.daemon_pid);
    out.set("sequence", s.sequence).set("age_ms", (now_ns - s.published_ns) / 1'000'000);
    out.set("drive_count", s.drive_count).set("drives_online", s.drives_online);
    out.set("control_group", shm::view(s.control_group)).set("can_request", can_request);
    out.set("counters", counters_json(bus_counters(s.counters)));
    out.set("reply_latency", timing_json(s.reply_latency)).set("extra_gap", timing_json(s.extra_gap));
    out.set("drives", drives_json(s));
    return out;
}

std::vector<Row> drive_rows(const shm::BusStatus& s) {
    std::vector<Row> rows = {{"NAME", "ADDRESS", "PROFILE", "HEALTH", "TIME-OUT"}};
    for (std::size_t i = 0; i < s.drive_count && i < s.drives.size(); ++i) {
        const auto& d = s.drives[i];
        rows.push_back({std::string(shm::view(d.name)), std::to_string(d.address), std::string(shm::view(d.profile)),
                        std::string(shm::to_string(d.health)),
                        comm_timeout_cell(d.comm_timeout_state, d.comm_timeout_verdict, d.comm_timeout_ms)});
    }
    return rows;
}

Json drives_json(const shm::BusStatus& s) {
    auto drives = Json::array();
    for (std::size_t i = 0; i < s.drive_count && i < s.drives.size(); ++i) {
        const auto& d = s.drives[i];
        drives.push(Json::object()
                        .set("name", shm::view(d.name))
                        .set("address", d.address)
                        .set("profile", shm::view(d.profile))
                        .set("health", shm::to_string(d.health))
                        .set("comm_timeout", Json::object()
                                                 .set("state", shm::to_string(d.comm_timeout_state))
                                                 .set("verdict", shm::to_string(d.comm_timeout_verdict))
                                                 .set("timeout_ms", d.comm_timeout_ms)));
    }
    return drives;
}

}  // namespace drivebus::ctl
