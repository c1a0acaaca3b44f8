// SPDX-License-Identifier: Apache-2.0
// One [[bus.drive.poll]]: registers resolved against the drive's profile, period, and the
// indirect read block's rules when the group goes through it.
#include <algorithm>
#include <map>

#include "read.hpp"

namespace drivebus::config::detail {
namespace {

using namespace std::chrono_literals;

std::string element(std::size_t index) {
    return "registers[" + std::to_string(index) + "]";
}

// A name of the profile (any case), or a number: "0xFD00", "64768" or 64768. A number the
// profile does not name is allowed: the ATV58's full word list is not in its profile.
std::optional<PolledRegister> resolve(Section& s, const Profile& profile, const toml::node& node, std::size_t index) {
    const auto key = element(index);
    const RegisterInfo* info = nullptr;
    std::optional<std::int64_t> number;
    std::string written;
    if (const auto* text = node.as_string()) {
        written = text->get();
        info = profile.find(written);
        if (info == nullptr) {
            number = settings::key_integer(written);
            if (!number) {
                s.fail(key + " " + in_quotes(written) + " is not a register of " + title_of(profile));
                return std::nullopt;
            }
        }
    } else if (const auto* value = node.as_integer()) {
        number = value->get();
        written = std::to_string(*number);
    } else {
        s.fail(key + " must be a register name or number");
        return std::nullopt;
    }
    if (number) {
        if (*number < 0 || *number > 0xFFFF) {
            s.fail(key + " " + written + " is not a register number (0-65535)");
            return std::nullopt;
        }
        const auto address = static_cast<std::uint16_t>(*number);
        info = profile.find(address);
        if (info == nullptr) {
            return PolledRegister{hex4(address), address};
        }
    }
    if (!info->address) {
        s.fail(key + " " + info->name + " has no Modbus address in the " + title_of(profile) + " profile");
        return std::nullopt;
    }
    if (!readable(info->access)) {
        s.fail(key + " " + info->name + " is write-only");
        return std::nullopt;
    }
    return PolledRegister{info->name, *info->address};
}

// A poll group while its keys are read, with the drive's profile its registers resolve against.
struct PollDraft {
    PollGroup poll;
    const Profile* profile = nullptr;  // null: its loading failed and was reported
};

using PollKeys = Keys<PollDraft>;

void read_name(Section& s, const toml::table& /*table*/, const Key<PollDraft>& key, PollDraft& draft) {
    if (auto name = s.string(key.name)) {
        if (!valid_name(*name)) {
            s.fail("name " + in_quotes(*name) + " is not made of a-z, 0-9, '_' and '-'");
        }
        draft.poll.name = std::move(*name);
    }
}

void read_registers(Section& s, const toml::table& table, const Key<PollDraft>& key, PollDraft& draft) {
    const auto* node = table.get(key.name);
    if (node == nullptr) {
        s.fail("missing key " + in_quotes(key.name));
        return;
    }
    const auto* array = node->as_array();
    if (array == nullptr) {
        s.fail(std::string(key.name) + " must be an array of register names or numbers, e.g. [\"FD00\", \"0xFD01\"]");
        return;
    }
    if (array->empty()) {
        s.fail(std::string(key.name) + " is empty");
        return;
    }
    if (draft.profile == nullptr) {
        return;  // its loading failed and was reported
    }
    std::map<std::uint16_t, std::size_t> seen;
    for (std::size_t i = 0; i < array->size(); ++i) {
        auto reg = resolve(s, *draft.profile, (*array)[i], i);
        if (!reg) {
            return;
        }
        if (const auto [it, fresh] = seen.emplace(reg->address, i); !fresh) {
            s.fail(element(i) + " " + reg->name + " is already " + element(it->second));
            return;
        }
        draft.poll.registers.push_back(std::move(*reg));
    }
}

std::string shown_numbered(const Key<PollDraft>& /*key*/) {
    return "\"group<N>\"";  // N counts from 1: read_poll() names it
}

constexpr Table<PollDraft, 4> kPollKeys = {
    PollKeys::custom("name", "string", Need::Optional, words("[a-z0-9_-]+"), read_name, shown_numbered,
                     "unique in the drive"),
    PollKeys::custom("registers", "array", Need::Required, words("not empty, no register twice"), read_registers,
                     nullptr, "register names or numbers, read in the order given"),
    PollKeys::duration<&PollDraft::poll, &PollGroup::period>("period", 1ms, 1h, "how often the group is read",
                                                             Need::Required),
    PollKeys::boolean<&PollDraft::poll, &PollGroup::indirect>("indirect",
                                                              "read through the profile's indirect read block"),
};

// One FC03 at the block's address returns the registers its selectors chose, in slot order.
void check_indirect(Section& s, const Profile& profile, const PollGroup& poll) {
    const auto* block = profile.block(3);
    const auto title = title_of(profile);
    if (block == nullptr) {
        s.fail("indirect = true, but " + title + " has no indirect read block");
        return;
    }
    const auto count = poll.registers.size();
    if (count > block->max_quantity || count < block->min_quantity) {
        s.fail("the indirect read block of " + title + " reads " + std::to_string(block->min_quantity) + "-" +
               std::to_string(block->max_quantity) + " registers, not " + std::to_string(count));
        return;
    }
    std::string choices;
    for (const auto& [value, name] : block->choices) {
        choices.append(choices.empty() ? "" : ", ").append(name);
    }
    for (std::size_t i = 0; i < count; ++i) {
        const auto& name = poll.registers[i].name;
        if (std::ranges::find(block->choices, name, [](const auto& entry) { return entry.second; }) ==
            block->choices.end()) {
            s.fail(element(i) + " " + name + " is not one the indirect read block of " + title + " can select (" +
                   choices + ")");
            return;
        }
    }
}

}  // namespace

PollGroup read_poll(const toml::table& table, std::size_t index, const std::string& drive, const Profile* profile,
                    Errors& errors) {
    Section s(table, drive + " " + entry_name("poll", index), errors);
    if (const auto* name = table.get_as<std::string>("name"); name != nullptr && valid_name(name->get())) {
        s.rename(drive + " poll " + in_quotes(name->get()));
    }
    allow_only(s, table, {}, kPollKeys);
    PollDraft draft{{}, profile};
    auto& poll = draft.poll;
    poll.name = "group" + std::to_string(index + 1);
    read_keys(s, table, kPollKeys, draft);
    if (poll.indirect && profile != nullptr && !errors.any()) {
        check_indirect(s, *profile, poll);
    }
    return std::move(poll);
}

SectionReference poll_reference() {
    return described("[[bus.drive.poll]]", kPollKeys);
}

}  // namespace drivebus::config::detail
