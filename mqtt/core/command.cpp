// SPDX-License-Identifier: Apache-2.0
#include "mqtt/command.hpp"

#include <array>
#include <charconv>
#include <cmath>
#include <utility>

#include "duration/duration.hpp"

namespace drivebus::mqtt {
namespace {

constexpr std::array<std::pair<std::string_view, Verb>, 7> kVerbs = {{
    {"run", Verb::Run},
    {"run_reverse", Verb::RunReverse},
    {"stop", Verb::Stop},
    {"freewheel", Verb::Freewheel},
    {"reset_fault", Verb::ResetFault},
    {"heartbeat", Verb::Heartbeat},
    {"release", Verb::Release},
}};

std::expected<Verb, std::string> verb_of(const Json& value) {
    if (!value.is_string()) {
        return std::unexpected("verb: not a string");
    }
    const auto& text = value.get_ref<const std::string&>();
    for (const auto& [name, verb] : kVerbs) {
        if (text == name) {
            return verb;
        }
    }
    return std::unexpected("verb: unknown verb '" + text.substr(0, 32) +
                           "' (run, run_reverse, stop, freewheel, reset_fault, heartbeat, release)");
}

std::expected<RegisterValue, std::string> register_value(const std::string& name, const Json& value) {
    RegisterValue r{.name = name, .value = {}, .raw = {}};
    if (value.is_number()) {
        r.value = value.get<double>();
        if (!std::isfinite(*r.value)) {
            return std::unexpected("registers: " + name + ": not a finite number");
        }
        return r;
    }
    if (value.is_object() && value.size() == 1 && value.contains("raw") && value["raw"].is_number_integer()) {
        r.raw = value["raw"].get<std::int64_t>();
        return r;
    }
    return std::unexpected("registers: " + name + ": give a number (engineering value) or {\"raw\": word}");
}

// A register by profile name or number ("FA01", "0xFA01", "64001").
std::optional<std::uint16_t> number_of(std::string_view text) {
    int base = 10;
    if (text.starts_with("0x") || text.starts_with("0X")) {
        text.remove_prefix(2);
        base = 16;
    }
    unsigned value = 0;
    const auto* end = text.data() + text.size();
    const auto [ptr, ec] = std::from_chars(text.data(), end, value, base);
    if (text.empty() || ec != std::errc() || ptr != end || value > 0xFFFF) {
        return std::nullopt;
    }
    return static_cast<std::uint16_t>(value);
}

std::expected<Action, std::string> write_of(const RegisterValue& r, const Profile* profile) {
    const RegisterInfo* info = nullptr;
    std::optional<std::uint16_t> address;
    if (profile != nullptr) {
        info = profile->find(r.name);
        if (info == nullptr) {
            if (const auto n = number_of(r.name)) {
                info = profile->find(*n);
                address = n;
            }
        } else {
            address = info->address;
        }
        if (info == nullptr && !profile->registers.empty()) {
            return std::unexpected("unknown register '" + r.name.substr(0, 32) + "' for the " + profile->type +
                                   " profile");
        }
    } else {
        address = number_of(r.name);
    }
    if (!address) {
        return std::unexpected("register '" + r.name.substr(0, 32) + "' has no Modbus address");
    }
    if (info != nullptr && info->access == Access::Read) {
        return std::unexpected("register " + info->name + " is read-only");
    }
    Action a{.kind = Action::Kind::Write, .address = *address, .raw = 0, .name = info ? info->name : r.name};
    if (r.raw) {
        if (*r.raw < 0 || *r.raw > 0xFFFF) {
            return std::unexpected("register " + a.name + ": raw " + std::to_string(*r.raw) + " is not a 16-bit word");
        }
        a.raw = static_cast<std::uint16_t>(*r.raw);
        if (info != nullptr && !info->in_range(a.raw)) {
            return std::unexpected("register " + a.name + ": raw " + std::to_string(*r.raw) +
                                   " is outside the profile's range");
        }
        return a;
    }
    if (!r.value) {
        return std::unexpected("register " + a.name + ": no value");
    }
    const double value = *r.value;
    if (info == nullptr) {
        if (value < 0 || value > 0xFFFF || std::floor(value) != value) {
            return std::unexpected("register " + a.name + ": without a profile, give a word 0-65535");
        }
        a.raw = static_cast<std::uint16_t>(value);
        return a;
    }
    const auto raw = info->from_engineering(value);
    if (!raw) {
        return std::unexpected("register " + a.name + ": " + Json(value).dump() +
                               (info->unit.empty() ? "" : " " + info->unit) + " is outside the profile's range");
    }
    a.raw = *raw;
    return a;
}

std::expected<Action, std::string> verb_write(Verb verb, const Profile* profile) {
    if (profile == nullptr || !profile->control) {
        return std::unexpected("verb " + std::string(to_string(verb)) +
                               ": the drive's profile has no [control] section");
    }
    const auto& c = *profile->control;
    std::optional<std::uint16_t> word;
    switch (verb) {
    case Verb::Run: word = c.run_forward; break;
    case Verb::RunReverse: word = c.run_reverse; break;
    case Verb::Stop: word = c.stop; break;
    case Verb::Freewheel: word = c.freewheel; break;
    case Verb::ResetFault: word = c.fault_reset; break;
    default: break;
    }
    const auto* info = profile->find(c.command);
    if (!word || info == nullptr || !info->address) {
        return std::unexpected("verb " + std::string(to_string(verb)) + ": the " + profile->type +
                               " profile has no command word for it");
    }
    return Action{.kind = Action::Kind::Write, .address = *info->address, .raw = *word, .name = info->name};
}

}  // namespace

std::string_view to_string(Verb verb) noexcept {
    for (const auto& [name, v] : kVerbs) {
        if (v == verb) {
            return name;
        }
    }
    return "none";
}

std::expected<Command, CommandError> parse_command(std::string_view payload, std::size_t max_payload) {
    if (payload.size() > max_payload) {
        return std::unexpected(CommandError{nullptr, "payload of " + std::to_string(payload.size()) +
                                                         " bytes is larger than the limit of " +
                                                         std::to_string(max_payload)});
    }
    Json j = Json::parse(payload, nullptr, false);
    if (j.is_discarded()) {
        return std::unexpected(CommandError{nullptr, "not JSON"});
    }
    if (!j.is_object()) {
        return std::unexpected(CommandError{nullptr, "not a JSON object"});
    }
    Command c;
    const auto id = j.find("id");
    if (id == j.end() || !(id->is_string() || id->is_number_integer()) ||
        (id->is_string() &&
         (id->get_ref<const std::string&>().empty() || id->get_ref<const std::string&>().size() > 128))) {
        return std::unexpected(CommandError{nullptr, "id: a string of 1-128 characters or an integer is required"});
    }
    c.id = *id;
    const auto fail = [&](std::string message) { return std::unexpected(CommandError{c.id, std::move(message)}); };
    for (const auto& [key, value] : j.items()) {
        if (key == "id") {
            continue;
        }
        if (key == "registers") {
            if (!value.is_object() || value.empty()) {
                return fail("registers: an object of register names and values");
            }
            for (const auto& [name, v] : value.items()) {
                auto r = register_value(name, v);
                if (!r) {
                    return fail(r.error());
                }
                c.registers.push_back(std::move(*r));
            }
        } else if (key == "frequency") {
            if (!value.is_number() || !std::isfinite(value.get<double>())) {
                return fail("frequency: a number (Hz)");
            }
            c.frequency = value.get<double>();
        } else if (key == "verb") {
            auto v = verb_of(value);
            if (!v) {
                return fail(v.error());
            }
            c.verb = *v;
        } else if (key == "not_after" || key == "sent_at") {
            auto t = parse_time(value);
            if (!t) {
                return fail(key + ": " + t.error());
            }
            (key == "not_after" ? c.freshness.not_after : c.freshness.sent_at) = *t;
        } else if (key == "max_age") {
            if (!value.is_string()) {
                return fail("max_age: a duration such as \"2s\" or \"500ms\"");
            }
            const auto d = parse_duration(value.get_ref<const std::string&>());
            if (!d) {
                return fail("max_age: " + d.error());
            }
            if (*d <= std::chrono::nanoseconds::zero() || *d > std::chrono::hours(24)) {
                return fail("max_age: must be more than 0 and at most 24 h");
            }
            c.freshness.max_age = *d;
        } else {
            return fail("unknown key '" + key.substr(0, 32) +
                        "' (id, registers, frequency, verb, not_after, max_age, sent_at)");
        }
    }
    if (c.registers.empty() && !c.frequency && c.verb == Verb::None) {
        return fail("nothing to do: give registers, frequency or verb");
    }
    if ((c.verb == Verb::Heartbeat || c.verb == Verb::Release) && (!c.registers.empty() || c.frequency)) {
        return fail("verb " + std::string(to_string(c.verb)) + " goes alone");
    }
    return c;
}

std::expected<std::vector<Action>, std::string> plan(const Command& command, const Profile* profile) {
    std::vector<Action> actions;
    for (const auto& r : command.registers) {
        auto a = write_of(r, profile);
        if (!a) {
            return std::unexpected(a.error());
        }
        actions.push_back(std::move(*a));
    }
    if (command.frequency) {
        if (profile == nullptr) {
            return std::unexpected("frequency: the drive has no profile");
        }
        const auto reference = frequency_reference(*profile);
        if (!reference) {
            return std::unexpected("frequency: " + reference.error());
        }
        auto a = write_of({.name = (*reference)->name, .value = command.frequency, .raw = {}}, profile);
        if (!a) {
            return std::unexpected("frequency: " + a.error());
        }
        actions.push_back(std::move(*a));
    }
    switch (command.verb) {
    case Verb::None: break;
    case Verb::Heartbeat:
        actions.push_back({.kind = Action::Kind::KeepAlive, .address = 0, .raw = 0, .name = {}});
        break;
    case Verb::Release: actions.push_back({.kind = Action::Kind::Release, .address = 0, .raw = 0, .name = {}}); break;
    default: {
        auto a = verb_write(command.verb, profile);
        if (!a) {
            return std::unexpected(a.error());
        }
        actions.push_back(std::move(*a));
    }
    }
    return actions;
}

Json result_ok(const Json& id) {
    return Json{{"id", id}, {"ok", true}};
}

Json result_error(const Json& id, std::string_view reason, std::string_view message) {
    return Json{{"id", id}, {"ok", false}, {"reason", std::string(reason)}, {"error", std::string(message)}};
}

}  // namespace drivebus::mqtt
