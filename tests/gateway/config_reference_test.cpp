// SPDX-License-Identifier: Apache-2.0
// drivebus-gateway's configuration against its documentation (tests/support/doc_reference.hpp):
// docs/gateway.md and drivebus-gateway(8) state every key of [gateway] and [[unit]] as the
// reader's tables do; and the reader takes every key its tables list and no other.
#include <gtest/gtest.h>

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "doc_reference.hpp"
#include "gateway/config.hpp"

namespace drivebus::gateway {
namespace {

TEST(GatewayReference, SectionsInReadingOrderWithUniqueKeys) {
    const auto sections = reference();
    docs::expect_well_formed(sections);
    std::vector<std::string> names;
    for (const auto& section : sections) {
        names.push_back(section.name);
    }
    EXPECT_EQ(names, (std::vector<std::string>{"[gateway]", "[[unit]]"}));
}

TEST(GatewayReference, TheDocumentationHasEveryKeyWithTheReadersTypeDefaultAndRange) {
    docs::expect_documented("docs/gateway.md", reference());
}

TEST(GatewayReference, TheManPageIntroducesEveryKeyUnderItsSection) {
    docs::expect_in_man_page("man/drivebus-gateway.8", reference());
}

// A valid file with `key = value` in `section` (a [[unit]] routes unit 10 to the pump).
std::string with(std::string_view section, const std::string& key, const std::string& value) {
    std::string gateway = "[gateway]\nlisten = \"127.0.0.1:0\"\n";
    std::string unit = "[[unit]]\nid = 10\ndrive = \"pump\"\n";
    auto& text = section == "[gateway]" ? gateway : unit;
    if (!key.empty()) {
        const auto line = text.find("\n" + key + " =");
        if (line != std::string::npos) {
            text.erase(line + 1, text.find('\n', line + 1) - line);
        }
        text += key + " = " + value + "\n";
    }
    return gateway + unit;
}

TEST(GatewayReference, TheReaderTakesEveryKeyOfTheTablesAndNoOther) {
    docs::expect_reader_takes_every_key(
        reference(),
        [](const auto& section, const auto& key, const auto& value) { return with(section.name, key, value); },
        [](const std::string& text) -> std::optional<std::string> {
            auto config = parse_config(text, "gateway.toml");
            return config ? std::nullopt : std::optional(config.error().message);
        });
}

// The durations are kept in milliseconds: a finer value is refused, not cut.
TEST(GatewayReference, ADurationFinerThanAMillisecondIsRefused) {
    const auto config = parse_config("[gateway]\nmax_age = \"1500us\"\n", "gateway.toml");
    ASSERT_FALSE(config);
    EXPECT_EQ(config.error().message, "gateway.toml: gateway: max_age 1500us is not a whole number of ms");
    const auto whole = parse_config("[gateway]\nmax_age = \"1.5s\"\n", "gateway.toml");
    ASSERT_TRUE(whole) << whole.error().message;
    EXPECT_EQ(whole->max_age, std::chrono::milliseconds(1500));
}

// One mistake, one wording: drivebusd's configuration says the same of its own keys
// (config_tests: "realtime: send_spin 2ms is above 1ms").
TEST(GatewayReference, MistakesAreWordedAsDrivebusdWordsThem) {
    const auto error = [](std::string_view text) {
        const auto config = parse_config(text, "gateway.toml");
        return config ? std::string("accepted") : config.error().message;
    };
    EXPECT_EQ(error("[gateway]\nrequest_timeout = \"61s\"\n"),
              "gateway.toml: gateway: request_timeout 61s is above 60s");
    EXPECT_EQ(error("[gateway]\nrequest_timeout = \"10ms\"\n"),
              "gateway.toml: gateway: request_timeout 10ms is below 50ms");
    EXPECT_EQ(error("[gateway]\nmax_age = 100\n"),
              "gateway.toml: gateway: max_age must be a string with a unit, e.g. \"100ms\", not a bare number");
    EXPECT_EQ(error("[gateway]\nworkers = 65\n"), "gateway.toml: gateway: workers 65 is above 64");
    EXPECT_EQ(error("[[unit]]\nid = 3\n"), "gateway.toml: unit 3: missing key 'drive'");
    // The text after the position is toml++'s own, which its versions word differently.
    const auto syntax = error("[gateway\n");
    EXPECT_TRUE(syntax.starts_with("gateway.toml: line 1, column 9: ")) << syntax;
    EXPECT_EQ(syntax.find('\n'), std::string::npos) << syntax;
}

}  // namespace
}  // namespace drivebus::gateway
