// SPDX-License-Identifier: Apache-2.0
// drivebus-mqtt's configuration against its documentation (tests/support/doc_reference.hpp):
// docs/mqtt.md states every key of each table as the reader's tables do, and drivebus-mqtt(1)'s
// example file is one the reader takes; the reader takes every key its tables list and no other.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "doc_reference.hpp"
#include "mqtt/config.hpp"

namespace drivebus::mqtt {
namespace {

TEST(MqttReference, SectionsInReadingOrderWithUniqueKeys) {
    const auto sections = reference();
    docs::expect_well_formed(sections);
    std::vector<std::string> names;
    for (const auto& section : sections) {
        names.push_back(section.name);
    }
    EXPECT_EQ(names, (std::vector<std::string>{"top level", "[broker]", "[broker.tls]", "[limits]", "[[bus]]",
                                               "[[bus.drive]]"}));
}

TEST(MqttReference, TheDocumentationHasEveryKeyWithTheReadersTypeDefaultAndRange) {
    docs::expect_documented("docs/mqtt.md", reference());
}

// The man page shows the whole file as an example (.nf to .fi under CONFIGURATION).
TEST(MqttReference, TheManPagesExampleIsAValidFileWithEveryTable) {
    std::ifstream in(std::filesystem::path(DRIVEBUS_TEST_SOURCE_DIR) / "man/drivebus-mqtt.1");
    ASSERT_TRUE(in);
    std::string example;
    bool configuration = false;
    bool inside = false;
    for (std::string line; std::getline(in, line);) {
        if (line.starts_with(".SH ")) {
            configuration = line == ".SH CONFIGURATION";
        } else if (configuration && line == ".nf") {
            inside = true;
        } else if (inside && line == ".fi") {
            break;
        } else if (inside) {
            for (auto dash = line.find("\\-"); dash != std::string::npos; dash = line.find("\\-")) {
                line.replace(dash, 2, "-");
            }
            example += line + "\n";
        }
    }
    ASSERT_FALSE(example.empty()) << "no example under .SH CONFIGURATION";
    // Its password file is not on this machine: the example is read without that line.
    std::string readable = example;
    const auto password = readable.find("password_file = ");
    ASSERT_NE(password, std::string::npos);
    readable.erase(password, readable.find('\n', password) + 1 - password);
    const auto config = parse_config(readable, "drivebus-mqtt.1", "board");
    EXPECT_TRUE(config) << config.error().message;
    for (const auto& section : reference()) {
        const auto header = section.name == "top level" ? std::string() : section.name + "\n";
        EXPECT_TRUE(header.empty() || example.find(header) != std::string::npos)
            << "the example has no " << section.name;
        for (const auto& key : section.keys) {
            EXPECT_NE(example.find(key.key + " = "), std::string::npos)
                << "the example has no key " << key.key << " (" << section.name << ")";
        }
    }
}

// A valid file with `key = value` in `section`.
std::string with(std::string_view section, const std::string& key, const std::string& value) {
    std::vector<std::pair<std::string, std::string>> tables = {{"top level", ""},
                                                               {"[broker]", "[broker]\n"},
                                                               {"[broker.tls]", "[broker.tls]\ncafile = \"ca.pem\"\n"},
                                                               {"[limits]", "[limits]\n"},
                                                               {"[[bus]]", "[[bus]]\nname = \"line1\"\n"},
                                                               {"[[bus.drive]]", "[[bus.drive]]\nname = \"pump\"\n"}};
    std::string out;
    for (auto& [name, text] : tables) {
        if (name == section && !key.empty()) {
            const auto line = text.find(key + " =");
            if (line != std::string::npos) {
                text.erase(line, text.find('\n', line) + 1 - line);
            }
            text += key + " = " + value + "\n";
        }
        out += text;
    }
    return out;
}

TEST(MqttReference, TheReaderTakesEveryKeyOfTheTablesAndNoOther) {
    docs::expect_reader_takes_every_key(
        reference(),
        [](const auto& section, const auto& key, const auto& value) { return with(section.name, key, value); },
        [](const std::string& text) -> std::optional<std::string> {
            auto config = parse_config(text, "mqtt.toml", "board");
            return config ? std::nullopt : std::optional(config.error().message);
        });
}

// One mistake, one wording: drivebusd and drivebus-gateway say the same of their own keys.
TEST(MqttReference, MistakesAreWordedAsDrivebusdWordsThem) {
    const auto error = [](std::string_view text) {
        const auto config = parse_config(std::string(text) + "[[bus]]\nname = \"line1\"\n", "mqtt.toml", "board");
        return config ? std::string("accepted") : config.error().message;
    };
    EXPECT_EQ(error("[broker]\nkeepalive = \"61min\"\n"), "mqtt.toml: broker: keepalive 61min is above 3600s");
    EXPECT_EQ(error("[broker]\nkeepalive = 30\n"),
              "mqtt.toml: broker: keepalive must be a string with a unit, e.g. \"100ms\", not a bare number");
    EXPECT_EQ(error("[limits]\ncommand_queue = 0\n"), "mqtt.toml: limits: command_queue 0 is below 1");
    EXPECT_EQ(error("[broker]\nreconnect_min = \"5s\"\nreconnect_max = \"2s\"\n"),
              "mqtt.toml: broker: reconnect_max 2s is below reconnect_min 5s");
    EXPECT_EQ(error("[broker.tls]\ncafile = \"\"\n"), "mqtt.toml: broker.tls: cafile is empty");
}

}  // namespace
}  // namespace drivebus::mqtt
