// SPDX-License-Identifier: Apache-2.0
// drivebusctl's JSON values (nlohmann-json underneath): escaping, numbers, order of keys; what it
// writes reads back.
#include <gtest/gtest.h>

#include <cmath>

#include "json.hpp"
#include "read_json.hpp"

namespace drivebus::ctl {
namespace {

TEST(CtlJson, StringsAreEscaped) {
    const auto quote = [](std::string_view text) { return Json(text).dump(); };
    EXPECT_EQ(quote("plain"), "\"plain\"");
    EXPECT_EQ(quote("a\"b\\c"), "\"a\\\"b\\\\c\"");
    EXPECT_EQ(quote("line\nnext\ttab\r"), "\"line\\nnext\\ttab\\r\"");
    EXPECT_EQ(quote(std::string("\x01\x1f", 2)), "\"\\u0001\\u001f\"");
    EXPECT_EQ(quote("30 °C"), "\"30 °C\"");  // UTF-8 passes through
    EXPECT_EQ(quote(""), "\"\"");
    // Not UTF-8 (a device name can be any bytes): replaced, still one valid document.
    const auto odd = quote(std::string("tty\xff", 4));
    EXPECT_EQ(test::json::parse(odd).str(), "tty\xEF\xBF\xBD");
}

TEST(CtlJson, ValuesAndNesting) {
    auto doc = Json::object()
                   .set("name", "pump")
                   .set("address", std::uint8_t{1})
                   .set("raw", std::uint16_t{65535})
                   .set("negative", -5)
                   .set("value", 30.5)
                   .set("whole", 30.0)
                   .set("up", true)
                   .set("none", Json())
                   .set("nan", std::nan(""))
                   .set("list", Json::array().push(1).push("two").push(Json::object()));
    EXPECT_EQ(doc.dump(), R"({"name":"pump","address":1,"raw":65535,"negative":-5,"value":30.5,"whole":30,"up":true,)"
                          R"("none":null,"nan":null,"list":[1,"two",{}]})");
}

TEST(CtlJson, SettingAKeyAgainReplacesIt) {
    auto doc = Json::object().set("a", 1).set("b", 2).set("a", 3);
    EXPECT_EQ(doc.dump(), R"({"a":3,"b":2})");
}

TEST(CtlJson, WhatItWritesParses) {
    const std::string nasty = std::string("quote\" backslash\\ newline\n control\x02 end");
    const auto text = Json::object().set(nasty, Json::array().push(nasty).push(-1.25)).dump();
    const auto back = test::json::parse(text);
    EXPECT_EQ(back[nasty][0].str(), nasty);
    EXPECT_DOUBLE_EQ(back[nasty][1].num(), -1.25);
    EXPECT_EQ(text.find('\n'), std::string::npos);  // one line
}

TEST(CtlJson, MisuseThrows) {
    auto array = Json::array();
    EXPECT_THROW(array.set("a", 1), std::logic_error);
    auto object = Json::object();
    EXPECT_THROW(object.push(1), std::logic_error);
}

}  // namespace
}  // namespace drivebus::ctl
