// SPDX-License-Identifier: Apache-2.0
// The profile loader: the two real profiles and the manuals' facts in them, look-ups, value
// conversions, the search path, and one test per validation rule.
#include <gtest/gtest.h>

#include <unistd.h>
#include "one_line_error.hpp"
#include "scratch_dir.hpp"

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "drivebus/profile.hpp"

namespace drivebus {
namespace {

namespace fs = std::filesystem;

fs::path profile_dir() {
    return DRIVEBUS_TEST_PROFILE_DIR;
}

Profile load_real(std::string_view name) {
    auto profile = load_profile(profile_dir() / (std::string(name) + ".toml"));
    if (!profile) {
        ADD_FAILURE() << profile.error().message;
        return {};
    }
    return *profile;
}

// A small profile that passes every check; each validation test changes one thing in it.
constexpr std::string_view kValid = R"(schema = 1

[drive]
type = "test"
title = "Test drive"
vendor = "Nobody"
address_min = 1
address_max = 31
bauds = [9600, 19200]
parities = ["none", "even"]
factory_baud = 19200
factory_parity = "even"
data_bits = 8
stop_bits = 1

[functions]
read_holding_max = 10
write_multiple_max = 8
write_single = true
broadcast = [6, 16]
device_identification = true

[identification]
vendor_name = "Nobody"
product_code = "T1"
revision = "0100"

[[register]]
name = "FA01"
address = 0xFA01
title = "Frequency reference"
access = "rw"
unit = "Hz"
scale = 0.01
min = 0
max = 10000
default = 0
group = "control"
note = "a note"
[register.values]
0 = "Stopped"

[[register]]
name = "ST"
address = 0x0010
access = "r"
signed = true
scale = 0.1
min = -1000
max = 1000
group = "monitoring"
[register.bits]
15 = "Sign"

[[register]]
name = "S1"
address = 0x0100
access = "rw"

[[register]]
name = "S2"
address = 0x0101
access = "rw"

[[register]]
name = "NOADDR"
access = "rw"

[[fault_code]]
code = 1
name = "E1"
title = "Fault one"

[[indirect_block]]
function = 3
address = 0x1000
min_quantity = 1
max_quantity = 2
selectors = ["S1", "S2"]
choices = { 1 = "FA01", 2 = "ST" }
)";

// kValid with the first `from` replaced by `to`.
std::string edited(std::string_view from, std::string_view to) {
    std::string text(kValid);
    const auto at = text.find(from);
    if (at == std::string::npos) {
        ADD_FAILURE() << "not in the valid profile: " << from;
        return text;
    }
    return text.replace(at, from.size(), to);
}

// The text is rejected with one line that names the file and every one of `parts`.
::testing::AssertionResult rejected(std::string_view text, std::initializer_list<std::string_view> parts) {
    const auto profile = parse_profile(text, "test.toml");
    if (profile) {
        return ::testing::AssertionFailure() << "parsed without error";
    }
    return drivebus::test::one_line_error(profile.error().message, "test.toml", parts);
}

// Sets an environment variable for one test and restores it after. Tests run single-threaded.
// NOLINTBEGIN(concurrency-mt-unsafe)
class ScopedEnv {
public:
    ScopedEnv(const char* name, const char* value) : name_(name) {
        if (const char* old = std::getenv(name)) {
            old_ = old;
        }
        if (value != nullptr) {
            ::setenv(name, value, 1);
        } else {
            ::unsetenv(name);
        }
    }
    ~ScopedEnv() {
        if (old_) {
            ::setenv(name_, old_->c_str(), 1);
        } else {
            ::unsetenv(name_);
        }
    }
    ScopedEnv(const ScopedEnv&) = delete;
    ScopedEnv& operator=(const ScopedEnv&) = delete;
    ScopedEnv(ScopedEnv&&) = delete;
    ScopedEnv& operator=(ScopedEnv&&) = delete;

private:
    const char* name_;
    std::optional<std::string> old_;
};
// NOLINTEND(concurrency-mt-unsafe)

using drivebus::test::ScratchDir;

// ---------------------------------------------------------------------------------------------
// The real profiles

TEST(RealProfiles, BothLoad) {
    const auto atv21 = load_profile(profile_dir() / "atv21.toml");
    ASSERT_TRUE(atv21) << atv21.error().message;
    EXPECT_EQ(atv21->type, "atv21");
    EXPECT_EQ(atv21->title, "Altivar 21");
    EXPECT_GT(atv21->registers.size(), 50U);
    const auto atv58 = load_profile(profile_dir() / "atv58.toml");
    ASSERT_TRUE(atv58) << atv58.error().message;
    EXPECT_EQ(atv58->type, "atv58");
    EXPECT_EQ(atv58->registers.size(), 12U);  // W400, W401, W450..W459
}

TEST(Atv21, FrequencyReferenceFA01) {
    const auto p = load_real("atv21");
    const auto* fa01 = p.find("FA01");
    ASSERT_NE(fa01, nullptr);
    EXPECT_EQ(fa01->address, 0xFA01);
    EXPECT_EQ(fa01->access, Access::ReadWrite);
    EXPECT_DOUBLE_EQ(fa01->scale, 0.01);
    EXPECT_EQ(fa01->unit, "Hz");
    EXPECT_EQ(fa01->min, 0);
    EXPECT_FALSE(fa01->max.has_value());  // the maximum is the drive's FH, not a constant
}

// A frequency goes to the reference only when the profile gives it in Hz: the ATV21's FA01 in
// 0.01 Hz; the ATV58's W401 has no unit or scale in any source, so 50 Hz is never written as 50.
TEST(FrequencyReference, OnlyAReferenceInHzTakesAFrequency) {
    const auto atv21 = load_real("atv21");
    const auto fa01 = frequency_reference(atv21);
    ASSERT_TRUE(fa01) << fa01.error();
    EXPECT_EQ((*fa01)->name, "FA01");
    EXPECT_EQ((*fa01)->from_engineering(50.0), 5000);
    const auto atv58 = load_real("atv58");
    const auto w401 = frequency_reference(atv58);
    ASSERT_FALSE(w401);
    EXPECT_NE(w401.error().find("the atv58 profile gives its frequency reference W401 no unit and scale"),
              std::string::npos)
        << w401.error();
    auto percent = atv21;
    for (auto& r : percent.registers) {
        if (r.name == "FA01") {
            r.unit = "%";
        }
    }
    EXPECT_NE(frequency_reference(percent).error().find("the unit '%'"), std::string::npos);
    auto none = atv21;
    none.control.reset();
    EXPECT_NE(frequency_reference(none).error().find("names no frequency reference"), std::string::npos);
}

TEST(Atv21, OutputFrequencyFD00IsReadOnly) {
    const auto p = load_real("atv21");
    const auto* fd00 = p.find("FD00");
    ASSERT_NE(fd00, nullptr);
    EXPECT_EQ(fd00->address, 0xFD00);
    EXPECT_EQ(fd00->access, Access::Read);
    EXPECT_TRUE(readable(fd00->access));
    EXPECT_FALSE(writable(fd00->access));
}

TEST(Atv21, ModbusTimeoutF803) {
    const auto p = load_real("atv21");
    const auto* f803 = p.find("F803");
    ASSERT_NE(f803, nullptr);
    EXPECT_EQ(f803->address, 0x0803);
    EXPECT_EQ(f803->default_value, 3);
    EXPECT_EQ(f803->min, 0);
    EXPECT_EQ(f803->max, 100);
    EXPECT_EQ(f803->unit, "s");
}

TEST(Atv21, ReadIndirectBlock) {
    const auto p = load_real("atv21");
    const auto* block = p.block(3);
    ASSERT_NE(block, nullptr);
    EXPECT_EQ(block->address, 0x1875);
    EXPECT_EQ(block->min_quantity, 2);
    EXPECT_EQ(block->max_quantity, 5);
    EXPECT_EQ(block->selectors, (std::vector<std::string>{"F875", "F876", "F877", "F878", "F879"}));
    ASSERT_TRUE(block->choices.contains(2));
    EXPECT_EQ(block->choices.at(2), "FD00");
    EXPECT_FALSE(block->choices.contains(0));   // 0 is "no selection", not a register
    EXPECT_TRUE(block->selectors_after_reset);  // section 6: "Activation: Après réinitialisation"
}

TEST(Atv21, WriteIndirectBlock) {
    const auto p = load_real("atv21");
    const auto* block = p.block(16);
    ASSERT_NE(block, nullptr);
    EXPECT_EQ(block->address, 0x1870);
    EXPECT_EQ(block->min_quantity, 2);
    EXPECT_EQ(block->max_quantity, 2);
    EXPECT_EQ(block->selectors, (std::vector<std::string>{"F870", "F871"}));
    EXPECT_EQ(block->choices.at(3), "FA01");
    EXPECT_TRUE(block->selectors_after_reset);
    EXPECT_EQ(p.block(6), nullptr);
}

TEST(Atv21, FaultCodes) {
    const auto p = load_real("atv21");
    const auto* err5 = p.fault(24);
    ASSERT_NE(err5, nullptr);
    EXPECT_EQ(err5->name, "Err5");
    ASSERT_NE(p.fault(13), nullptr);
    EXPECT_EQ(p.fault(13)->name, "OL1");  // printed as hex "P" in the guide
    EXPECT_EQ(p.fault(6), nullptr);
}

TEST(Atv21, Identification) {
    const auto p = load_real("atv21");
    ASSERT_TRUE(p.identification.has_value());
    EXPECT_EQ(p.identification->vendor_name, "Schneider Electric");
    EXPECT_EQ(p.identification->product_code, "ATV21H075M3X");
    EXPECT_EQ(p.identification->revision, "0201");
    EXPECT_TRUE(p.functions.device_identification);
}

TEST(Atv21, LineAndFunctionLimits) {
    const auto p = load_real("atv21");
    EXPECT_EQ(p.address_min, 1);
    EXPECT_EQ(p.address_max, 247);
    EXPECT_EQ(p.bauds, (std::vector<std::uint32_t>{9600, 19200}));
    EXPECT_EQ(p.factory_baud, 19200U);
    EXPECT_EQ(p.factory_parity, "even");
    EXPECT_FALSE(p.data_bits.has_value());
    EXPECT_EQ(p.functions.read_holding_max, 1);
    EXPECT_EQ(p.functions.write_multiple_max, 1);
    EXPECT_EQ(p.functions.broadcast, (std::vector<std::uint8_t>{6, 16}));
}

TEST(Atv21, RegistersWithoutAddress) {
    const auto p = load_real("atv21");
    for (const char* name : {"CMOD", "FMOD"}) {
        SCOPED_TRACE(name);
        const auto* r = p.find(name);
        ASSERT_NE(r, nullptr);
        EXPECT_FALSE(r->address.has_value());
    }
}

TEST(Atv58, LineAndFunctionLimits) {
    const auto p = load_real("atv58");
    EXPECT_EQ(p.address_min, 1);
    EXPECT_EQ(p.address_max, 31);
    EXPECT_EQ(p.functions.read_holding_max, 32);
    EXPECT_EQ(p.functions.write_multiple_max, 30);
    EXPECT_TRUE(p.functions.write_single);
    EXPECT_EQ(p.functions.broadcast, (std::vector<std::uint8_t>{6, 16}));
    EXPECT_FALSE(p.functions.device_identification);
    EXPECT_FALSE(p.identification.has_value());
    EXPECT_TRUE(p.indirect_blocks.empty());
    EXPECT_EQ(p.bauds, (std::vector<std::uint32_t>{19200}));
    EXPECT_EQ(p.parities, (std::vector<std::string>{"none"}));
    EXPECT_EQ(p.data_bits, 8);
    EXPECT_EQ(p.stop_bits, 1);
}

TEST(Atv58, SupervisionWords) {
    const auto p = load_real("atv58");
    const auto* w450 = p.find("W450");
    ASSERT_NE(w450, nullptr);
    EXPECT_EQ(w450->address, 450);
    EXPECT_EQ(w450->access, Access::Read);
    EXPECT_EQ(p.find(std::uint16_t{450}), w450);
    ASSERT_NE(p.find("W459"), nullptr);
    EXPECT_EQ(p.find("W459")->address, 459);
    ASSERT_NE(p.find("W400"), nullptr);
    EXPECT_EQ(p.find("W400")->address, 400);
    EXPECT_EQ(p.find("W400")->access, Access::ReadWrite);
}

// ---------------------------------------------------------------------------------------------
// Look-ups

TEST(Lookup, NamesAreCaseInsensitive) {
    const auto p = load_real("atv21");
    const auto* fa01 = p.find("FA01");
    ASSERT_NE(fa01, nullptr);
    EXPECT_EQ(p.find("fa01"), fa01);
    EXPECT_EQ(p.find("Fa01"), fa01);
    EXPECT_EQ(p.find("cmod"), p.find("CMOD"));
    EXPECT_EQ(p.find("FA0"), nullptr);
    EXPECT_EQ(p.find("FA011"), nullptr);
    EXPECT_EQ(p.find(""), nullptr);
}

TEST(Lookup, ByAddress) {
    const auto p = load_real("atv21");
    const auto* r = p.find(std::uint16_t{0xFD00});
    ASSERT_NE(r, nullptr);
    EXPECT_EQ(r->name, "FD00");
    ASSERT_NE(p.find(std::uint16_t{0x0803}), nullptr);
    EXPECT_EQ(p.find(std::uint16_t{0x0803})->name, "F803");
    EXPECT_EQ(p.find(std::uint16_t{0x1875}), nullptr);  // a block window, not a register
}

// ---------------------------------------------------------------------------------------------
// Conversions

TEST(Conversions, FrequencyReference60Hz) {
    const auto p = load_real("atv21");
    const auto* fa01 = p.find("FA01");
    ASSERT_NE(fa01, nullptr);
    EXPECT_DOUBLE_EQ(fa01->to_engineering(6000), 60.0);
    EXPECT_EQ(fa01->from_engineering(60.0), 6000);
    EXPECT_EQ(fa01->from_engineering(80.0), 0x1F40);  // the guide's 80 Hz example
    EXPECT_EQ(fa01->from_engineering(59.996), 6000);  // nearest, not truncated
    EXPECT_EQ(fa01->from_engineering(59.994), 5999);
    EXPECT_EQ(fa01->from_engineering(655.35), 65535);
}

TEST(Conversions, OutOfRangeIsNullopt) {
    const auto p = load_real("atv21");
    const auto* fa01 = p.find("FA01");
    const auto* f803 = p.find("F803");
    ASSERT_NE(fa01, nullptr);
    ASSERT_NE(f803, nullptr);
    EXPECT_EQ(fa01->from_engineering(-0.01), std::nullopt);   // below min 0
    EXPECT_EQ(fa01->from_engineering(655.36), std::nullopt);  // 65536 does not fit a word
    EXPECT_EQ(fa01->from_engineering(std::numeric_limits<double>::quiet_NaN()), std::nullopt);
    EXPECT_EQ(fa01->from_engineering(std::numeric_limits<double>::infinity()), std::nullopt);
    EXPECT_EQ(f803->from_engineering(100.0), 100);
    EXPECT_EQ(f803->from_engineering(101.0), std::nullopt);  // above max 100
    EXPECT_TRUE(f803->in_range(3));
    EXPECT_TRUE(f803->in_range(100));
    EXPECT_FALSE(f803->in_range(101));
    EXPECT_FALSE(f803->in_range(0xFFFF));
}

TEST(Conversions, SignedRegister) {
    const auto p = parse_profile(kValid, "test.toml");
    ASSERT_TRUE(p) << p.error().message;
    const auto* st = p->find("ST");  // signed, scale 0.1, -1000..1000
    ASSERT_NE(st, nullptr);
    EXPECT_DOUBLE_EQ(st->to_engineering(0xFFF6), -1.0);
    EXPECT_DOUBLE_EQ(st->to_engineering(0x03E8), 100.0);
    EXPECT_EQ(st->from_engineering(-1.0), 0xFFF6);
    EXPECT_EQ(st->from_engineering(-100.0), 0xFC18);
    EXPECT_EQ(st->from_engineering(-100.1), std::nullopt);
    EXPECT_EQ(st->from_engineering(100.1), std::nullopt);
    EXPECT_TRUE(st->in_range(0xFC18));   // -1000
    EXPECT_FALSE(st->in_range(0xFC17));  // -1001
    EXPECT_TRUE(st->in_range(0x03E8));   // 1000
    EXPECT_FALSE(st->in_range(0x03E9));  // 1001
}

TEST(Conversions, WordLimitsWithoutMinMax) {
    const RegisterInfo word;
    EXPECT_EQ(word.from_engineering(65535.0), 0xFFFF);
    EXPECT_EQ(word.from_engineering(65536.0), std::nullopt);
    EXPECT_EQ(word.from_engineering(-1.0), std::nullopt);
    EXPECT_DOUBLE_EQ(word.to_engineering(0xFFF6), 65526.0);
    EXPECT_TRUE(word.in_range(0xFFFF));

    RegisterInfo signed_word;
    signed_word.is_signed = true;
    EXPECT_EQ(signed_word.from_engineering(-32768.0), 0x8000);
    EXPECT_EQ(signed_word.from_engineering(-32769.0), std::nullopt);
    EXPECT_EQ(signed_word.from_engineering(32767.0), 0x7FFF);
    EXPECT_EQ(signed_word.from_engineering(32768.0), std::nullopt);
    EXPECT_DOUBLE_EQ(signed_word.to_engineering(0x8000), -32768.0);
    EXPECT_TRUE(signed_word.in_range(0x8000));
}

// ---------------------------------------------------------------------------------------------
// Parsing a valid profile

TEST(Parse, ValidInlineProfile) {
    const auto p = parse_profile(kValid, "test.toml");
    ASSERT_TRUE(p) << p.error().message;
    EXPECT_EQ(p->type, "test");
    EXPECT_EQ(p->registers.size(), 5U);
    EXPECT_EQ(p->find("FA01")->address, 0xFA01);  // hex integer
    EXPECT_EQ(p->find("FA01")->values.at(0), "Stopped");
    EXPECT_EQ(p->find("ST")->bits.at(15), "Sign");
    EXPECT_FALSE(p->find("NOADDR")->address.has_value());
    EXPECT_EQ(p->fault(1)->title, "Fault one");
    EXPECT_EQ(p->block(3)->choices.at(2), "ST");
}

TEST(Parse, BlockNamesTakeTheRegistersSpelling) {
    const auto p = parse_profile(edited(R"(selectors = ["S1", "S2"])", R"(selectors = ["s1", "S2"])"), "test.toml");
    ASSERT_TRUE(p) << p.error().message;
    EXPECT_EQ(p->block(3)->selectors.at(0), "S1");
}

TEST(Parse, DefaultsWhenOptionalTablesAreAbsent) {
    const auto p = parse_profile("schema = 1\n[drive]\ntype = \"bare\"\n", "bare.toml");
    ASSERT_TRUE(p) << p.error().message;
    EXPECT_EQ(p->address_min, 1);
    EXPECT_EQ(p->address_max, 247);
    EXPECT_EQ(p->functions.read_holding_max, 125);
    EXPECT_EQ(p->functions.write_multiple_max, 123);
    EXPECT_TRUE(p->registers.empty());
}

// ---------------------------------------------------------------------------------------------
// Validation: one test per rule

TEST(Validation, TomlSyntaxError) {
    const std::string_view anchor = "access = \"rw\"\nunit";
    const auto line = 1 + std::ranges::count(kValid.substr(0, kValid.find(anchor)), '\n');
    EXPECT_TRUE(rejected(edited(anchor, "access = rw\nunit"), {": line " + std::to_string(line) + ", column "}));
}

TEST(Validation, UnknownKeys) {
    EXPECT_TRUE(rejected(edited("schema = 1", "schema = 1\ncolour = 1"), {"unknown key 'colour'"}));
    EXPECT_TRUE(rejected(edited("vendor = \"Nobody\"", "vendr = \"Nobody\""), {"drive: ", "unknown key 'vendr'"}));
    EXPECT_TRUE(
        rejected(edited("write_single = true", "write_singel = true"), {"functions: ", "unknown key 'write_singel'"}));
    EXPECT_TRUE(
        rejected(edited("revision = \"0100\"", "revison = \"0100\""), {"identification: ", "unknown key 'revison'"}));
    EXPECT_TRUE(
        rejected(edited("access = \"rw\"\nunit", "acess = \"rw\"\nunit"), {"register FA01: ", "unknown key 'acess'"}));
    EXPECT_TRUE(
        rejected(edited("title = \"Fault one\"", "titel = \"Fault one\""), {"fault_code 1: ", "unknown key 'titel'"}));
    EXPECT_TRUE(rejected(edited("min_quantity = 1", "min_qty = 1"), {"indirect_block #1: ", "unknown key 'min_qty'"}));
}

TEST(Validation, UnknownKeyWithControlCharacterStaysOneLine) {
    EXPECT_TRUE(rejected(edited("schema = 1", "schema = 1\n\"a\\nb\" = 1"), {"unknown key 'a\\x0Ab'"}));
}

TEST(Validation, MissingSchema) {
    EXPECT_TRUE(rejected(edited("schema = 1\n", ""), {"missing key 'schema'"}));
}

TEST(Validation, MissingDriveType) {
    EXPECT_TRUE(rejected(edited("type = \"test\"\n", ""), {"drive: ", "missing key 'type'"}));
    EXPECT_TRUE(rejected("schema = 1\n", {"missing key 'drive'"}));
}

TEST(Validation, MissingRegisterName) {
    EXPECT_TRUE(rejected(edited("name = \"FA01\"\n", ""), {"register #1: ", "missing key 'name'"}));
}

TEST(Validation, MissingRegisterAccess) {
    EXPECT_TRUE(rejected(edited("access = \"rw\"\nunit", "unit"), {"register FA01: ", "missing key 'access'"}));
}

TEST(Validation, MissingFaultCodeAndBlockKeys) {
    EXPECT_TRUE(rejected(edited("code = 1\n", ""), {"fault_code #1: ", "missing key 'code'"}));
    EXPECT_TRUE(rejected(edited("address = 0x1000\n", ""), {"indirect_block #1: ", "missing key 'address'"}));
}

TEST(Validation, WrongTypes) {
    EXPECT_TRUE(rejected(edited("address = 0xFA01", "address = \"0xFA01\""),
                         {"register FA01: ", "address must be an integer, not a string"}));
    EXPECT_TRUE(rejected(edited("min = 0\nmax = 10000", "min = 0.0\nmax = 10000"),
                         {"register FA01: ", "min must be an integer, not a floating-point number"}));
    EXPECT_TRUE(rejected(edited("scale = 0.01", "scale = \"0.01\""), {"register FA01: ", "scale must be a number"}));
    EXPECT_TRUE(rejected(edited("signed = true", "signed = 1"), {"register ST: ", "signed must be a boolean"}));
    EXPECT_TRUE(rejected(edited("title = \"Frequency reference\"", "title = 5"),
                         {"register FA01: ", "title must be a string"}));
    EXPECT_TRUE(rejected(edited("bauds = [9600, 19200]", "bauds = 9600"), {"drive: ", "bauds must be an array"}));
    EXPECT_TRUE(rejected(edited("bauds = [9600, 19200]", "bauds = [9600, \"19200\"]"),
                         {"drive: ", "bauds[1] must be an integer"}));
    EXPECT_TRUE(rejected(edited("0 = \"Stopped\"", "0 = 7"), {"register FA01: ", "values.0 must be a string"}));
    EXPECT_TRUE(rejected("schema = 1\n[drive]\ntype = \"t\"\n[register]\nname = \"X\"\naccess = \"r\"\n",
                         {"register must be an array of tables ([[register]]), not a table"}));
    EXPECT_TRUE(rejected("schema = 1\nfunctions = 3\n[drive]\ntype = \"t\"\n", {"functions must be a table"}));
}

TEST(Validation, AccessNotRWOrRW) {
    EXPECT_TRUE(rejected(edited("access = \"rw\"\nunit", "access = \"ro\"\nunit"),
                         {"register FA01: ", "access 'ro' is not r, w or rw"}));
    EXPECT_TRUE(rejected(edited("access = \"rw\"\nunit", "access = \"RW\"\nunit"), {"access 'RW'"}));
}

TEST(Validation, AddressOutOfRange) {
    EXPECT_TRUE(
        rejected(edited("address = 0xFA01", "address = 0x10000"), {"register FA01: ", "address 65536 is above 65535"}));
    EXPECT_TRUE(rejected(edited("address = 0xFA01", "address = -1"), {"register FA01: ", "address -1 is below 0"}));
    EXPECT_TRUE(rejected(edited("address = 0x1000", "address = 0x10000"),
                         {"indirect_block #1: ", "address 65536 is above 65535"}));
}

TEST(Validation, MinMaxOutsideTheWord) {
    EXPECT_TRUE(rejected(edited("max = 10000", "max = 70000"), {"register FA01: ", "max 70000 is above 65535"}));
    EXPECT_TRUE(rejected(edited("max = 1000\n", "max = 40000\n"), {"register ST: ", "max 40000 is above 32767"}));
}

TEST(Validation, MinAboveMax) {
    EXPECT_TRUE(
        rejected(edited("min = 0\nmax = 10000", "min = 10\nmax = 5"), {"register FA01: ", "min 10 is above max 5"}));
}

TEST(Validation, DefaultOutsideMinMax) {
    EXPECT_TRUE(rejected(edited("default = 0\n", "default = 10001\n"),
                         {"register FA01: ", "default 10001 is above max 10000"}));
    EXPECT_TRUE(rejected(edited("min = 0\nmax = 10000\ndefault = 0", "min = 5\nmax = 10000\ndefault = 4"),
                         {"register FA01: ", "default 4 is below min 5"}));
}

TEST(Validation, DuplicateRegisterNamesIgnoringCase) {
    EXPECT_TRUE(
        rejected(edited("name = \"S2\"", "name = \"fa01\""), {"register fa01: ", "name repeats register FA01"}));
}

TEST(Validation, DuplicateAddresses) {
    EXPECT_TRUE(rejected(edited("address = 0x0101", "address = 0xFA01"),
                         {"register S2: ", "address 0xFA01 is already register FA01"}));
}

TEST(Validation, ScaleNotAboveZero) {
    EXPECT_TRUE(rejected(edited("scale = 0.01", "scale = 0"), {"register FA01: ", "scale 0 is not above 0"}));
    EXPECT_TRUE(rejected(edited("scale = 0.01", "scale = -0.5"), {"register FA01: ", "scale -0.5 is not above 0"}));
    EXPECT_TRUE(rejected(edited("scale = 0.01", "scale = nan"), {"register FA01: ", "scale nan is not above 0"}));
}

TEST(Validation, BitNumberAbove15) {
    EXPECT_TRUE(rejected(edited("15 = \"Sign\"", "16 = \"Sign\""), {"register ST: ", "bits key 16 is above 15"}));
    EXPECT_TRUE(rejected(edited("15 = \"Sign\"", "x = \"Sign\""), {"register ST: ", "bits key 'x' is not a number"}));
}

TEST(Validation, EnumeratedValueOutsideRange) {
    EXPECT_TRUE(rejected(edited("0 = \"Stopped\"", "10001 = \"Stopped\""),
                         {"register FA01: ", "values key 10001 is above max 10000"}));
}

TEST(Validation, BlockMinQuantityAboveMax) {
    EXPECT_TRUE(rejected(edited("min_quantity = 1", "min_quantity = 3"),
                         {"indirect_block #1: ", "min_quantity 3 is above max_quantity 2"}));
}

TEST(Validation, BlockMaxQuantityAboveSelectors) {
    EXPECT_TRUE(rejected(edited("max_quantity = 2", "max_quantity = 3"),
                         {"indirect_block #1: ", "max_quantity 3 is above the number of selectors (2)"}));
}

TEST(Validation, BlockChoiceNotARegister) {
    EXPECT_TRUE(rejected(edited("2 = \"ST\"", "2 = \"FX99\""),
                         {"indirect_block #1: ", "choices.2 'FX99' is not a register of this profile"}));
}

TEST(Validation, BlockSelectorNotARegister) {
    EXPECT_TRUE(rejected(edited(R"(selectors = ["S1", "S2"])", R"(selectors = ["S1", "S9"])"),
                         {"indirect_block #1: ", "selectors[1] 'S9' is not a register of this profile"}));
}

TEST(Validation, BlockSelectorsTakeEffectAtOnceOrAfterAReset) {
    EXPECT_TRUE(
        rejected(edited("function = 3", "function = 3\nselectors_take_effect = \"later\""),
                 {"indirect_block #1: ", "selectors_take_effect \"later\" is not \"at-once\" or \"after-reset\""}));
}

TEST(Validation, BlockFunctionNot3Or16) {
    EXPECT_TRUE(rejected(edited("function = 3", "function = 6"),
                         {"indirect_block #1: ", "function 6 is not 3 (read block) or 16 (write block)"}));
}

TEST(Validation, TwoBlocksForOneFunction) {
    const std::string second =
        "\n[[indirect_block]]\nfunction = 3\naddress = 0x2000\nmin_quantity = 1\n"
        "max_quantity = 1\nselectors = [\"S1\"]\n";
    EXPECT_TRUE(rejected(std::string(kValid) + second,
                         {"indirect_block #2: ", "function 3 already has a block (indirect_block #1)"}));
}

TEST(Validation, SchemaNotOne) {
    EXPECT_TRUE(rejected(edited("schema = 1", "schema = 2"), {"schema 2 is not supported"}));
    EXPECT_TRUE(rejected(edited("schema = 1", "schema = \"1\""), {"schema must be an integer"}));
}

TEST(Validation, SlaveAddressRange) {
    EXPECT_TRUE(rejected(edited("address_min = 1", "address_min = 0"), {"drive: ", "address_min 0 is below 1"}));
    EXPECT_TRUE(rejected(edited("address_max = 31", "address_max = 248"), {"drive: ", "address_max 248 is above 247"}));
    EXPECT_TRUE(
        rejected(edited("address_min = 1", "address_min = 40"), {"drive: ", "address_min 40 is above address_max 31"}));
}

TEST(Validation, BroadcastOnly6And16) {
    EXPECT_TRUE(rejected(edited("broadcast = [6, 16]", "broadcast = [6, 3]"),
                         {"functions: ", "broadcast[1] 3: only functions 6 and 16 may be broadcast"}));
    EXPECT_TRUE(rejected(edited("broadcast = [6, 16]", "broadcast = [6, 6]"),
                         {"functions: ", "broadcast[1] 6 is listed twice"}));
}

TEST(Validation, FunctionLimitsWithinTheSpec) {
    EXPECT_TRUE(rejected(edited("read_holding_max = 10", "read_holding_max = 126"),
                         {"functions: ", "read_holding_max 126 is above 125"}));
    EXPECT_TRUE(rejected(edited("write_multiple_max = 8", "write_multiple_max = 0"),
                         {"functions: ", "write_multiple_max 0 is below 1"}));
}

TEST(Validation, DriveTypeIsAFileName) {
    EXPECT_TRUE(rejected(edited("type = \"test\"", "type = \"../Test\""),
                         {"drive: ", "type '../Test' is not made of a-z, 0-9, '_' and '-'"}));
}

TEST(Validation, RegisterNameCharacters) {
    EXPECT_TRUE(rejected(edited("name = \"S2\"", "name = \"S 2\""), {"register #4: ", "name 'S 2' is not made of"}));
}

TEST(Validation, UnknownGroup) {
    EXPECT_TRUE(rejected(edited("group = \"control\"", "group = \"controls\""),
                         {"register FA01: ", "group 'controls' is not one of"}));
}

TEST(Validation, SerialFormat) {
    EXPECT_TRUE(rejected(edited("parities = [\"none\", \"even\"]", "parities = [\"none\", \"mark\"]"),
                         {"drive: ", "parities[1] 'mark' is not one of none, even, odd"}));
    EXPECT_TRUE(rejected(edited("factory_baud = 19200", "factory_baud = 38400"),
                         {"drive: ", "factory_baud 38400 is not one of bauds"}));
    EXPECT_TRUE(rejected(edited("factory_parity = \"even\"", "factory_parity = \"odd\""),
                         {"drive: ", "factory_parity 'odd' is not one of parities"}));
    EXPECT_TRUE(rejected(edited("data_bits = 8", "data_bits = 9"), {"drive: ", "data_bits 9 is above 8"}));
    EXPECT_TRUE(rejected(edited("stop_bits = 1", "stop_bits = 0"), {"drive: ", "stop_bits 0 is below 1"}));
}

TEST(Validation, IdentificationNeedsTheFunction) {
    EXPECT_TRUE(rejected(edited("device_identification = true", "device_identification = false"),
                         {"identification: ", "functions.device_identification is not true"}));
}

TEST(Validation, DuplicateFaultCodes) {
    EXPECT_TRUE(rejected(std::string(kValid) + "\n[[fault_code]]\ncode = 1\nname = \"E1b\"\n",
                         {"fault_code 1: ", "code 1 is also fault_code #1"}));
}

// ---------------------------------------------------------------------------------------------
// Files and the search path

TEST(Files, MissingFileIsNamed) {
    const auto p = load_profile("/nonexistent-drivebus-dir/atv99.toml");
    ASSERT_FALSE(p);
    EXPECT_TRUE(p.error().message.starts_with("/nonexistent-drivebus-dir/atv99.toml: ")) << p.error().message;
}

TEST(Files, DirectoryIsNotAProfile) {
    const auto p = load_profile(profile_dir());
    ASSERT_FALSE(p);
    EXPECT_NE(p.error().message.find("not a regular file"), std::string::npos) << p.error().message;
}

TEST(Files, ErrorsNameTheFilePath) {
    const ScratchDir dir;
    dir.write("broken.toml", edited("access = \"rw\"\nunit", "access = \"x\"\nunit"));
    const auto p = load_profile(dir.path() / "broken.toml");
    ASSERT_FALSE(p);
    EXPECT_TRUE(p.error().message.starts_with((dir.path() / "broken.toml").string() + ": register FA01: access"))
        << p.error().message;
}

// The site's directory (etc/) comes before the installed one (share/): a site profile of the
// same type overrides the packaged one for the daemon and every client alike.
TEST(SearchPath, EnvironmentThenSourceTreeThenSiteThenInstallDir) {
    {
        const ScopedEnv env("DRIVEBUS_PROFILE_DIR", "/opt/site-profiles");
        const auto dirs = profile_search_path();
        ASSERT_EQ(dirs.size(), 4U);
        EXPECT_EQ(dirs[0], fs::path("/opt/site-profiles"));
        EXPECT_EQ(dirs[1], profile_dir());
        EXPECT_TRUE(dirs[2].string().ends_with("etc/drivebus/profiles")) << dirs[2];
        EXPECT_TRUE(dirs[3].string().ends_with("share/drivebus/profiles")) << dirs[3];
        EXPECT_TRUE(dirs[2].is_absolute());
        EXPECT_TRUE(dirs[3].is_absolute());
    }
    const ScopedEnv unset("DRIVEBUS_PROFILE_DIR", nullptr);
    const auto dirs = profile_search_path();
    ASSERT_EQ(dirs.size(), 3U);
    EXPECT_EQ(dirs[0], profile_dir());
}

TEST(SearchPath, LoadsFromTheSourceTree) {
    const ScopedEnv unset("DRIVEBUS_PROFILE_DIR", nullptr);
    const auto atv58 = load_profile_by_type("atv58");
    ASSERT_TRUE(atv58) << atv58.error().message;
    EXPECT_EQ(atv58->address_max, 31);
    const auto atv21 = load_profile_by_type("atv21");
    ASSERT_TRUE(atv21) << atv21.error().message;
    EXPECT_EQ(atv21->address_max, 247);
}

TEST(SearchPath, EnvironmentDirectoryComesFirst) {
    const ScratchDir dir;
    dir.write("atv58.toml", "schema = 1\n[drive]\ntype = \"atv58\"\ntitle = \"Site copy\"\n");
    const ScopedEnv env("DRIVEBUS_PROFILE_DIR", dir.path().c_str());
    const auto p = load_profile_by_type("atv58");
    ASSERT_TRUE(p) << p.error().message;
    EXPECT_EQ(p->title, "Site copy");
}

TEST(SearchPath, RejectsNamesThatAreNotPlainTypes) {
    for (const char* type : {"../profiles/atv21", "atv21/../atv58", "/etc/passwd", "ATV21", "atv21.toml", "", "a b"}) {
        SCOPED_TRACE(type);
        const auto p = load_profile_by_type(type);
        ASSERT_FALSE(p);
        EXPECT_NE(p.error().message.find("is not made of a-z, 0-9, '_' and '-'"), std::string::npos)
            << p.error().message;
    }
}

TEST(SearchPath, NotFoundSaysWhereItLooked) {
    const ScratchDir dir;
    const ScopedEnv env("DRIVEBUS_PROFILE_DIR", dir.path().c_str());
    const auto p = load_profile_by_type("nosuchdrive");
    ASSERT_FALSE(p);
    const auto& message = p.error().message;
    EXPECT_NE(message.find("nosuchdrive.toml"), std::string::npos) << message;
    EXPECT_NE(message.find(dir.path().string()), std::string::npos) << message;
    EXPECT_NE(message.find(profile_dir().string()), std::string::npos) << message;
    EXPECT_NE(message.find("/drivebus/profiles"), std::string::npos) << message;
}

TEST(SearchPath, FileMustDeclareItsOwnType) {
    const ScratchDir dir;
    dir.write("other.toml", "schema = 1\n[drive]\ntype = \"atv58\"\n");
    const ScopedEnv env("DRIVEBUS_PROFILE_DIR", dir.path().c_str());
    const auto p = load_profile_by_type("other");
    ASSERT_FALSE(p);
    EXPECT_NE(p.error().message.find("drive.type is 'atv58', not the file's name 'other'"), std::string::npos)
        << p.error().message;
}

// ---- [control] ----

TEST(Control, Atv21CommandWordsFromTheGuide) {
    const auto p = load_real("atv21");
    ASSERT_TRUE(p.control.has_value());
    const auto& c = *p.control;
    EXPECT_EQ(c.lease_registers, (std::vector<std::string>{"FA00", "FA01"}));
    EXPECT_EQ(c.command, "FA00");
    EXPECT_EQ(c.reference, "FA01");
    // Section 8.4: 0xC400 runs forward and 0xC600 in reverse with Modbus priority; bit 10 is
    // run, bit 11 freewheel, bit 13 fault reset.
    EXPECT_EQ(c.run_forward, 0xC400);
    EXPECT_EQ(c.run_reverse, 0xC600);
    EXPECT_EQ(c.stop, 0xC000);
    EXPECT_EQ(c.freewheel, 0xC800);
    EXPECT_EQ(c.fault_reset, 0xE000);
    EXPECT_EQ(c.status_bits.at("running"), 10U);
    EXPECT_EQ(c.status_bits.at("fault"), 1U);
}

TEST(Control, Atv58HasNoCommandWords) {
    const auto p = load_real("atv58");
    ASSERT_TRUE(p.control.has_value());
    EXPECT_EQ(p.control->lease_registers, (std::vector<std::string>{"W400", "W401"}));
    EXPECT_EQ(p.control->command, "W400");
    EXPECT_EQ(p.control->reference, "W401");
    // Its manual gives no value or bit of W400: no word to stop it with, so its lease can only hold.
    EXPECT_FALSE(p.control->stop.has_value());
    EXPECT_FALSE(p.control->freewheel.has_value());
    EXPECT_FALSE(p.control->run_forward.has_value());
    EXPECT_FALSE(p.control->run_reverse.has_value());
    EXPECT_FALSE(p.control->fault_reset.has_value());
    EXPECT_TRUE(p.control->status.empty());
}

TEST(Control, NamesTakeTheRegistersSpelling) {
    const auto p = parse_profile(
        std::string(kValid) + "\n[control]\nlease_registers = [\"fa01\"]\nreference = \"fa01\"\n", "test.toml");
    ASSERT_TRUE(p) << p.error().message;
    EXPECT_EQ(p->control->reference, "FA01");
    EXPECT_EQ(p->control->lease_registers.at(0), "FA01");
}

TEST(Control, Rejections) {
    const std::string base(kValid);
    EXPECT_TRUE(rejected(base + "\n[control]\ncommand = \"XX99\"\n", {"control", "XX99", "not a register"}));
    EXPECT_TRUE(rejected(base + "\n[control]\nreference = \"ST\"\n", {"control", "ST", "not writable"}));
    EXPECT_TRUE(rejected(base + "\n[control]\nstop = 3\n", {"control", "no command register"}));
    EXPECT_TRUE(rejected(base + "\n[control]\ncommand = \"FA01\"\nstop = 70000\n", {"control", "stop"}));
    EXPECT_TRUE(rejected(base + "\n[control]\nbrake = 1\n", {"control", "brake"}));
    EXPECT_TRUE(rejected(base + "\n[control]\nstatus_bits = { running = 16 }\n", {"status_bits", "running"}));
}

// ---------------------------------------------------------------------------------------------
// [safety]: the drive's own Modbus time-out

TEST(Safety, Atv21NamesF803AndF603) {
    const auto p = load_real("atv21");
    ASSERT_TRUE(p.safety.has_value());
    EXPECT_EQ(p.safety->comm_timeout, "F803");
    EXPECT_EQ(p.safety->comm_fault_action, "F603");
    EXPECT_EQ(p.safety->comm_timeout_seconds, 1.0);
    EXPECT_EQ(p.safety->comm_timeout_off, 0);
    EXPECT_EQ(p.safety->milliseconds(3), 3000U);  // the factory setting
    EXPECT_EQ(p.safety->milliseconds(0), 0U);     // off
    EXPECT_EQ(p.safety->milliseconds(100), 100000U);
}

TEST(Safety, Atv58NamesNone) {
    // Its manual names no time-out register.
    EXPECT_FALSE(load_real("atv58").safety.has_value());
}

// kValid with a time-out register (tenths of a second) and a [safety] table of `keys`.
std::string with_safety(std::string_view keys) {
    return std::string(kValid) +
           "\n[[register]]\nname = \"TO\"\naddress = 0x0200\naccess = \"rw\"\nunit = \"s\"\nscale = 0.1\n"
           "min = 0\nmax = 600\n\n[[register]]\nname = \"WO\"\naddress = 0x0201\naccess = \"w\"\n\n[safety]\n" +
           std::string(keys) + "\n";
}

TEST(Safety, ParsesAndTakesTheRegistersSpelling) {
    const auto p =
        parse_profile(with_safety("comm_timeout = \"to\"\ncomm_timeout_unit = \"0.1s\"\ncomm_timeout_off = 0\n"
                                  "comm_fault_action = \"s1\""),
                      "test.toml");
    ASSERT_TRUE(p) << p.error().message;
    EXPECT_EQ(p->safety->comm_timeout, "TO");
    EXPECT_EQ(p->safety->comm_fault_action, "S1");
    EXPECT_EQ(p->safety->milliseconds(25), 2500U);
    EXPECT_EQ(p->safety->milliseconds(0), 0U);
    // Without an "off" value, 0 is just 0 counts.
    const auto no_off = parse_profile(with_safety("comm_timeout = \"TO\"\ncomm_timeout_unit = \"0.1s\""), "t");
    ASSERT_TRUE(no_off) << no_off.error().message;
    EXPECT_FALSE(no_off->safety->comm_timeout_off.has_value());
}

TEST(Safety, Rejections) {
    const std::string_view unit = "comm_timeout_unit = \"0.1s\"";
    const auto both = [&](std::string_view more) { return with_safety(std::string(unit) + "\n" + std::string(more)); };
    EXPECT_TRUE(rejected(both("comm_timeout = \"XX99\""), {"safety: ", "comm_timeout 'XX99' is not a register"}));
    EXPECT_TRUE(rejected(both("comm_timeout = \"NOADDR\""), {"safety: ", "'NOADDR' has no address"}));
    EXPECT_TRUE(rejected(both("comm_timeout = \"WO\""), {"safety: ", "comm_timeout 'WO' is not readable"}));
    EXPECT_TRUE(rejected(both("comm_timeout = \"TO\"\ncomm_fault_action = \"XX\""),
                         {"safety: ", "comm_fault_action 'XX' is not a register"}));
    EXPECT_TRUE(rejected(with_safety("comm_timeout = \"TO\"\ncomm_timeout_unit = \"s\""),
                         {"safety: ", "comm_timeout_unit disagrees with register TO's unit \"s\" and scale 0.1"}));
    EXPECT_TRUE(rejected(with_safety("comm_timeout = \"TO\"\ncomm_timeout_unit = \"hour\""),
                         {"safety: ", "comm_timeout_unit 'hour' is not one of ms, 0.01s, 0.1s, s, min"}));
    EXPECT_TRUE(rejected(with_safety("comm_timeout = \"TO\""), {"safety: ", "without comm_timeout_unit"}));
    EXPECT_TRUE(rejected(with_safety("comm_timeout = \"FA01\"\ncomm_timeout_unit = \"s\""),
                         {"safety: ", "comm_timeout 'FA01' has unit \"Hz\", not a time"}));
    EXPECT_TRUE(rejected(both("comm_timeout = \"TO\"\ncomm_timeout_off = 601"),
                         {"safety: ", "comm_timeout_off 601 is outside register TO's range"}));
    EXPECT_TRUE(rejected(with_safety("comm_timeout_off = 0"), {"safety: ", "which is not given"}));
    EXPECT_TRUE(rejected(both("comm_timeout = \"TO\"\ncomm_timout = 1"), {"safety: ", "unknown key 'comm_timout'"}));
}

}  // namespace
}  // namespace drivebus
