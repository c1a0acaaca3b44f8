// SPDX-License-Identifier: Apache-2.0
// Drive profiles: what a type of drive is, as data (profiles/*.toml).
//
// The daemon, the client library, the CLI and the simulator all read the same profiles.
// A profile names each register as the drive's documents do (FA00, FD01, W450), with its
// Modbus address, access, unit, scale, range and bit or value meanings, and states the
// drive's function limits and indirect blocks.
#pragma once

#include <cstdint>
#include <expected>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace drivebus {

enum class Access : std::uint8_t { Read, Write, ReadWrite };

[[nodiscard]] constexpr bool readable(Access a) noexcept {
    return a != Access::Write;
}
[[nodiscard]] constexpr bool writable(Access a) noexcept {
    return a != Access::Read;
}

struct RegisterInfo {
    std::string name;                      // communication name: "FA01", "F803", "W450"
    std::optional<std::uint16_t> address;  // Modbus register; absent for a parameter with no number
    std::string title;
    Access access = Access::ReadWrite;
    std::string unit;                 // "Hz", "s", "%"; empty if none
    double scale = 1.0;               // engineering value = raw * scale
    std::optional<std::int32_t> min;  // raw units
    std::optional<std::int32_t> max;
    std::optional<std::int32_t> default_value;
    bool is_signed = false;  // two's complement
    std::string group;       // control, monitoring, communication, configuration, fault, io, identification
    std::string note;
    std::map<unsigned, std::string> bits;        // bit number -> meaning
    std::map<std::int32_t, std::string> values;  // enumerated value -> meaning

    // Engineering value of a raw word (sign and scale applied).
    [[nodiscard]] double to_engineering(std::uint16_t raw) const noexcept;
    // Raw word nearest to an engineering value; nullopt outside [min, max] or 16 bits.
    [[nodiscard]] std::optional<std::uint16_t> from_engineering(double value) const noexcept;
    // Whether a raw word lies inside [min, max] (as signed when is_signed).
    [[nodiscard]] bool in_range(std::uint16_t raw) const noexcept;
};

// A register window reached through selector parameters (the ATV21's indirect blocks).
struct IndirectBlock {
    std::uint8_t function = 3;  // 3: read block, 16: write block
    std::uint16_t address = 0;
    std::uint16_t min_quantity = 1;
    std::uint16_t max_quantity = 1;
    std::vector<std::string> selectors;            // selector parameter per slot, e.g. F875..F879
    std::map<std::uint16_t, std::string> choices;  // selector value -> register name
    // A selector written takes effect only after the drive is reset or powered up again (the
    // ATV21's F870-F879); until then the block keeps the selection it had.
    bool selectors_after_reset = false;
};

struct FunctionSupport {
    std::uint16_t read_holding_max = 125;    // FC03 words in a plain read
    std::uint16_t write_multiple_max = 123;  // FC16 words in a plain write
    bool write_single = true;                // FC06
    std::vector<std::uint8_t> broadcast;     // function codes that may go to address 0
    bool device_identification = false;      // FC43/14
};

struct Identification {
    std::string vendor_name;   // object 0
    std::string product_code;  // object 1
    std::string revision;      // object 2
};

struct FaultCode {
    std::uint16_t code = 0;
    std::string name;  // as the keypad shows it: "Err5"
    std::string title;
};

// How a drive is commanded: which registers a client's control lease covers, the command
// word values of the Altivar helpers and of the lease fallback, and where the state is read.
struct ControlInfo {
    std::vector<std::string> lease_registers;  // command and reference: writing one takes the lease
    std::string command;                       // the command word register ("FA00")
    std::string reference;                     // the frequency reference register ("FA01")
    std::string status;                        // the status word register ("FD01")
    std::string output_frequency;              // ("FD00")
    std::string fault;                         // present fault code ("FC90")
    std::string alarm;                         // alarm bits ("FC91")
    // Command word values.
    std::optional<std::uint16_t> run_forward;
    std::optional<std::uint16_t> run_reverse;
    std::optional<std::uint16_t> stop;       // ramp stop
    std::optional<std::uint16_t> freewheel;  // coast
    std::optional<std::uint16_t> fault_reset;
    // Status word bits: "running", "reverse", "fault", "alarm", "ready".
    std::map<std::string, unsigned> status_bits;
};

// The drive's own guard against a master that goes quiet (the ATV21's Modbus time-out, F803):
// the register that sets it, what one count of it is, the value that turns it off, and the
// register that says what the drive does when it fires (F603). drivebusd reads them when the
// drive comes online and warns when the guard is off or would fire between its requests.
struct SafetyInfo {
    std::string comm_timeout;                       // the time-out register ("F803"); empty: none named
    double comm_timeout_seconds = 1.0;              // seconds per raw count (comm_timeout_unit)
    std::optional<std::uint16_t> comm_timeout_off;  // the raw value that turns it off ("0: disabled")
    std::string comm_fault_action;                  // what the drive does when it fires ("F603"); empty: none

    // A raw time-out in milliseconds (0 for the value that turns it off).
    [[nodiscard]] std::uint32_t milliseconds(std::uint16_t raw) const noexcept;
};

struct Profile {
    int schema = 1;
    std::string type;   // "atv21"
    std::string title;  // "Altivar 21"
    std::string vendor;
    std::uint8_t address_min = 1;
    std::uint8_t address_max = 247;
    std::vector<std::uint32_t> bauds;
    std::vector<std::string> parities;  // "none", "even", "odd"
    std::optional<std::uint32_t> factory_baud;
    std::optional<std::string> factory_parity;
    std::optional<std::uint8_t> data_bits;  // 7 or 8; absent when the documents do not say
    std::optional<std::uint8_t> stop_bits;  // 1 or 2; absent when the documents do not say
    FunctionSupport functions;
    std::optional<Identification> identification;
    std::vector<IndirectBlock> indirect_blocks;
    std::vector<RegisterInfo> registers;
    std::vector<FaultCode> fault_codes;
    std::optional<ControlInfo> control;
    std::optional<SafetyInfo> safety;

    // Look-ups. Names match case-insensitively ("fa01" finds FA01).
    [[nodiscard]] const RegisterInfo* find(std::string_view name) const noexcept;
    [[nodiscard]] const RegisterInfo* find(std::uint16_t address) const noexcept;
    [[nodiscard]] const FaultCode* fault(std::uint16_t code) const noexcept;
    [[nodiscard]] const IndirectBlock* block(std::uint8_t function) const noexcept;
};

// The register a frequency in Hz is written to: the profile's [control] reference, when the
// profile gives it the unit "Hz" (and so its scale). Otherwise one line that names the profile
// and the register, and says why: a number of Hz is never written as a raw word by guess.
[[nodiscard]] std::expected<const RegisterInfo*, std::string> frequency_reference(const Profile& profile);

// One line that says where and what: "atv21.toml: register FA01: max 70000 is above 65535".
struct ProfileError {
    std::string message;
};

// Parses profile text; `source` names it in errors.
[[nodiscard]] std::expected<Profile, ProfileError> parse_profile(std::string_view text, std::string_view source);
// Reads and parses a profile file.
[[nodiscard]] std::expected<Profile, ProfileError> load_profile(const std::filesystem::path& file);

// Where profiles are looked for by type name, in order: $DRIVEBUS_PROFILE_DIR, the source
// tree's profiles/ (for builds run from the tree), the site's directory (/etc/drivebus/profiles
// for an install in /usr), the installed data directory.
[[nodiscard]] std::vector<std::filesystem::path> profile_search_path();
// Finds and loads "<type>.toml" along the search path.
[[nodiscard]] std::expected<Profile, ProfileError> load_profile_by_type(std::string_view type);

}  // namespace drivebus
