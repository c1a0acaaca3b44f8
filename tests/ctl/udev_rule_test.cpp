// SPDX-License-Identifier: Apache-2.0
// drivebusctl udev-rule's generator on the property samples of tests/ctl/udev/ (what
// `udevadm info --query=property` prints for each adapter family) and on the refusals.
#include "udev_rule.hpp"

#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

namespace drivebus::ctl::udev {
namespace {

std::string read(const std::string& path) {
    std::ifstream in(path);
    std::ostringstream text;
    text << in.rdbuf();
    return text.str();
}

Properties sample(const std::string& name) {
    auto p = parse_properties(read(std::string(UDEV_SAMPLES_DIR) + "/" + name + ".properties"));
    EXPECT_TRUE(p.has_value()) << name;
    return p.value_or(Properties{});
}

std::string rules(const Properties& p, const PortChoice& choice = {}) {
    auto text = rules_file(p, choice, {});
    EXPECT_TRUE(text.has_value()) << (text ? "" : text.error().message);
    return text.value_or("");
}

RuleError refusal(const Properties& p, const PortChoice& choice = {}) {
    auto text = rules_file(p, choice, {});
    EXPECT_FALSE(text.has_value()) << text.value_or("");
    return text ? RuleError{} : text.error();
}

PortChoice named(std::string name) {
    PortChoice c;
    c.name = std::move(name);
    return c;
}

PortChoice grouped(std::string group) {
    PortChoice c;
    c.group = std::move(group);
    return c;
}

PortChoice starting(std::string unit) {
    PortChoice c;
    c.start_unit = std::move(unit);
    return c;
}

PortChoice by_path() {
    PortChoice c;
    c.by_path = true;
    return c;
}

bool has(const std::string& text, std::string_view part) {
    return text.find(part) != std::string::npos;
}

// Every generated file: never a kernel name match, never a unit started unasked.
void expect_safe(const std::string& text) {
    EXPECT_FALSE(has(text, "KERNEL")) << text;
    EXPECT_FALSE(has(text, "SYSTEMD_WANTS")) << text;
    EXPECT_TRUE(has(text, R"(MODE="0660")")) << text;
}

TEST(UdevRule, Ft232rIsNamedBySerialNumberWithItsLatencyTimer) {
    const auto text = rules(sample("ft232r"));
    EXPECT_TRUE(has(text, "# /etc/udev/rules.d/60-drivebus-rs485-0.rules\n")) << text;
    EXPECT_TRUE(has(text, "#   sudo udevadm control --reload\n")) << text;
    EXPECT_TRUE(has(text, "#   sudo udevadm trigger --action=change --subsystem-match=tty\n")) << text;
    EXPECT_TRUE(has(text, R"(SUBSYSTEMS=="usb", IMPORT{builtin}="usb_id")")) << text;
    EXPECT_TRUE(has(text, R"(ENV{ID_VENDOR_ID}=="0403", ENV{ID_MODEL_ID}=="6001", ENV{ID_SERIAL_SHORT}=="A10KXYZ1", )"
                          R"(ENV{ID_USB_INTERFACE_NUM}=="00", SYMLINK+="drivebus/rs485-0", GROUP="drivebusd", )"
                          R"(MODE="0660", TAG+="systemd")"
                          "\n"))
        << text;
    // The latency timer on this adapter only: the same match, not DRIVERS=="ftdi_sio".
    EXPECT_TRUE(has(text, R"(ENV{ID_VENDOR_ID}=="0403", ENV{ID_MODEL_ID}=="6001", ENV{ID_SERIAL_SHORT}=="A10KXYZ1", )"
                          R"(ENV{ID_USB_INTERFACE_NUM}=="00", TEST=="device/latency_timer", )"
                          R"(ATTR{device/latency_timer}="1")"))
        << text;
    EXPECT_FALSE(has(text, "DRIVERS")) << text;
    EXPECT_TRUE(has(text, "dev-drivebus-rs485\\x2d0.device")) << text;
    expect_safe(text);
}

TEST(UdevRule, Ft4232PortIsPickedByItsInterfaceNumber) {
    const auto text = rules(sample("ft4232-port1"), named("line2"));
    EXPECT_TRUE(has(text, R"(ENV{ID_SERIAL_SHORT}=="FT4QUAD1", ENV{ID_USB_INTERFACE_NUM}=="01", )"
                          R"(SYMLINK+="drivebus/line2")"))
        << text;
    EXPECT_TRUE(has(text, "ATTR{device/latency_timer}=\"1\"")) << text;
    EXPECT_TRUE(has(text, "# /etc/udev/rules.d/60-drivebus-line2.rules\n")) << text;
    expect_safe(text);
}

TEST(UdevRule, Cp210xAndCdcAcmAreNamedBySerialNumberWithoutLatencyTimer) {
    const auto cp = rules(sample("cp2102"));
    EXPECT_TRUE(has(cp, R"(ENV{ID_VENDOR_ID}=="10c4", ENV{ID_MODEL_ID}=="ea60", )"
                        R"(ENV{ID_SERIAL_SHORT}=="5a4f3e2d1c0bea11b3a4c8d21e6f0a7c")"))
        << cp;
    EXPECT_FALSE(has(cp, "latency_timer")) << cp;
    expect_safe(cp);
    const auto acm = rules(sample("cdc-acm"));
    EXPECT_TRUE(
        has(acm, R"(ENV{ID_VENDOR_ID}=="0483", ENV{ID_MODEL_ID}=="5740", ENV{ID_SERIAL_SHORT}=="205E37A25748")"))
        << acm;
    EXPECT_TRUE(has(acm, "CDC-ACM device (0483:5740)")) << acm;
    EXPECT_FALSE(has(acm, "latency_timer")) << acm;
    expect_safe(acm);
}

TEST(UdevRule, AChipWithoutSerialNumberIsRefusedUnlessByPath) {
    for (const auto* name : {"ch340", "pl2303"}) {
        const auto e = refusal(sample(name));
        EXPECT_EQ(e.kind, RuleErrorKind::Refused) << name;
        EXPECT_TRUE(has(e.message, "has no serial number")) << e.message;
        EXPECT_TRUE(has(e.message, "--by-path")) << e.message;
        EXPECT_FALSE(has(e.message, "\n")) << e.message;
    }
    const auto text = rules(sample("ch340"), by_path());
    EXPECT_TRUE(has(text, R"(IMPORT{builtin}="path_id")")) << text;
    EXPECT_TRUE(has(text, R"(ENV{ID_VENDOR_ID}=="1a86", ENV{ID_MODEL_ID}=="7523", )"
                          R"(ENV{ID_PATH}=="platform-fd500000.pcie-pci-0000:01:00.0-usb-0:1.2:1.0")"))
        << text;
    EXPECT_TRUE(has(text, "as asked with --by-path")) << text;
    EXPECT_FALSE(has(text, "ID_SERIAL_SHORT")) << text;
    expect_safe(text);
    EXPECT_TRUE(has(rules(sample("pl2303"), by_path()), R"(ENV{ID_MODEL_ID}=="2303", ENV{ID_PATH}==)"));
}

TEST(UdevRule, AGenericSerialNumberIsRefusedUnlessByPath) {
    const auto e = refusal(sample("cp2102-clone"));
    EXPECT_EQ(e.kind, RuleErrorKind::Refused);
    EXPECT_TRUE(has(e.message, "\"0001\", which many adapters of its kind share")) << e.message;
    EXPECT_TRUE(has(rules(sample("cp2102-clone"), by_path()), "ENV{ID_PATH}"));
    for (const auto* serial : {"0001", "00000000", "A50285BI", "a50285bi", "FFFF", "0123456789ABCDEF", "1"}) {
        EXPECT_TRUE(generic_serial(serial)) << serial;
    }
    for (const auto* serial : {"A10KXYZ1", "FT4QUAD1", "205E37A25748", "0002"}) {
        EXPECT_FALSE(generic_serial(serial)) << serial;
    }
}

TEST(UdevRule, OnBoardUartsAreNamedByDevpathAnd8250GetsRxTrigBytes) {
    const auto pl011 = rules(sample("ttyAMA0"));
    EXPECT_TRUE(has(pl011,
                    R"(DEVPATH=="/devices/platform/soc/fe201000.serial/tty/ttyAMA0", SYMLINK+="drivebus/rs485-0", )"
                    R"(GROUP="drivebusd", MODE="0660", TAG+="systemd")"))
        << pl011;
    EXPECT_FALSE(has(pl011, "rx_trig_bytes")) << pl011;
    EXPECT_FALSE(has(pl011, "usb_id")) << pl011;
    expect_safe(pl011);
    const auto uart = rules(sample("ttyS1"));
    EXPECT_TRUE(has(uart, R"(DEVPATH=="/devices/pnp0/00:05/tty/ttyS1", SYMLINK+="drivebus/rs485-0")")) << uart;
    EXPECT_TRUE(
        has(uart, R"(DEVPATH=="/devices/pnp0/00:05/tty/ttyS1", TEST=="rx_trig_bytes", ATTR{rx_trig_bytes}="1")"))
        << uart;
    expect_safe(uart);
    // An 8250 port whose kernel name does not say so: the parent's driver does.
    auto dw = sample("ttyAMA0");
    dw["DEVNAME"] = "/dev/ttyS4";
    EXPECT_TRUE(has(rules(dw), "rx_trig_bytes"));
    dw["DEVNAME"] = "/dev/ttyX0";
    dw["DRIVER"] = "dw-apb-uart";
    EXPECT_TRUE(has(rules(dw), "rx_trig_bytes"));
}

TEST(UdevRule, ADeviceKnownOnlyByItsKernelNameOrVirtualIsRefused) {
    const auto e = refusal(sample("kernel-name-only"));
    EXPECT_EQ(e.kind, RuleErrorKind::Refused);
    EXPECT_TRUE(has(e.message, "/dev/ttyS1 has no DEVPATH")) << e.message;
    const Properties pty = {{"DEVPATH", "/devices/virtual/tty/ptmx"}, {"DEVNAME", "/dev/ptmx"}, {"SUBSYSTEM", "tty"}};
    EXPECT_TRUE(has(refusal(pty).message, "is a virtual device")) << refusal(pty).message;
    const Properties disk = {{"DEVPATH", "/devices/pci0000:00/0000:00:17.0/ata1/host0/target0:0:0/0:0:0:0/block/sda"},
                             {"DEVNAME", "/dev/sda"},
                             {"SUBSYSTEM", "block"}};
    EXPECT_TRUE(has(refusal(disk).message, "/dev/sda is not a serial port")) << refusal(disk).message;
    auto no_usb_id = sample("ft232r");
    no_usb_id.erase("ID_VENDOR_ID");
    no_usb_id.erase("ID_BUS");
    EXPECT_TRUE(has(refusal(no_usb_id).message, "no USB identity")) << refusal(no_usb_id).message;
}

TEST(UdevRule, AHostileSerialNumberIsRefusedInOneLine) {
    const auto e = refusal(sample("hostile-serial"));
    EXPECT_EQ(e.kind, RuleErrorKind::Refused);
    EXPECT_EQ(e.message,
              R"(ID_SERIAL_SHORT "A1\", RUN+=\"/bin/sh" contains '"', which would end or escape the rule's quoted )"
              "value: no rule written");
    for (const auto* bad : {"A\\1", "A*", "A?", "A[1]", "A|B", "A\nB", "A\x01", "A\x7f", "\xc3\xa9"}) {
        auto p = sample("ft232r");
        p["ID_SERIAL_SHORT"] = bad;
        const auto refused = refusal(p);
        EXPECT_EQ(refused.kind, RuleErrorKind::Refused) << bad;
        EXPECT_FALSE(has(refused.message, "\n")) << refused.message;
        EXPECT_TRUE(has(refused.message, "ID_SERIAL_SHORT")) << refused.message;
    }
    // The same for the other values a file quotes, comments included.
    for (const auto* key : {"DEVPATH", "ID_PATH", "ID_USB_INTERFACE_NUM", "DEVNAME", "ID_USB_DRIVER"}) {
        auto p = sample("ft232r");
        p[key] += "\nRUN+=\"/bin/sh\"";
        EXPECT_TRUE(has(refusal(p, by_path()).message, key)) << key;
    }
    EXPECT_FALSE(check_value("x", "A10K XYZ-1_.:/").has_value());
}

TEST(UdevRule, NamesGroupsAndUnitsAreChecked) {
    for (const auto* name : {"", "Rs485", "../x", "a b", "-x", ".x", "a/b", "a\"b", "rs485*"}) {
        const auto e = refusal(sample("ft232r"), named(name));
        EXPECT_EQ(e.kind, RuleErrorKind::Usage) << name;
        EXPECT_TRUE(has(e.message, "--name")) << e.message;
    }
    for (const auto* name : {"rs485-0", "line1", "a.b_c-d", "0"}) {
        EXPECT_FALSE(check_choice(named(name)).has_value()) << name;
    }
    for (const auto* group : {"", "Drivebus", "1x", "a b", "x\"", "drivebus\n"}) {
        EXPECT_EQ(refusal(sample("ft232r"), grouped(group)).kind, RuleErrorKind::Usage) << group;
    }
    EXPECT_TRUE(has(rules(sample("ft232r"), grouped("drivebus")), R"(GROUP="drivebus")"));
    for (const auto* unit : {"drivebusd", "drivebusd@.service", "a b.service", "x\".service", "-x.service"}) {
        EXPECT_EQ(refusal(sample("ft232r"), starting(unit)).kind, RuleErrorKind::Usage) << unit;
    }
    const auto started = rules(sample("ft232r"), starting("drivebusd@line1.service"));
    EXPECT_TRUE(has(started, R"(TAG+="systemd", ENV{SYSTEMD_WANTS}+="drivebusd@line1.service")"
                             "\n"))
        << started;
    EXPECT_TRUE(has(started, "asked with --start")) << started;
}

TEST(UdevRule, AGpioChipGoesToTheDaemonGroupOnly) {
    GpioChip chip{sample("gpiochip0"), "pinctrl-bcm2711", {{"line1", "gpiochip0", 17}}};
    auto text = rules_file(std::nullopt, {}, {chip});
    ASSERT_TRUE(text.has_value()) << text.error().message;
    EXPECT_TRUE(has(*text, "# /etc/udev/rules.d/60-drivebus-gpio.rules\n")) << *text;
    EXPECT_TRUE(has(*text, R"(SUBSYSTEM=="gpio", DEVPATH=="/devices/platform/soc/fe200000.gpio/gpiochip0", )"
                           R"(GROUP="drivebusd", MODE="0660")"
                           "\n"))
        << *text;
    EXPECT_TRUE(has(*text, "(label pinctrl-bcm2711)")) << *text;
    EXPECT_TRUE(has(*text, "bus 'line1' drives its transceiver's enable on line 17")) << *text;
    EXPECT_TRUE(has(*text, "drivebusd requests only line 17")) << *text;
    EXPECT_TRUE(has(*text, "not to single lines")) << *text;
    EXPECT_TRUE(has(*text, "--subsystem-match=gpio")) << *text;
    EXPECT_FALSE(has(*text, "gpiochip[")) << *text;
    expect_safe(*text);
    // The port's group choice does not reach the chip.
    auto both = rules_file(sample("ft232r"), grouped("drivebus"), {chip, chip});
    ASSERT_TRUE(both.has_value()) << both.error().message;
    EXPECT_TRUE(has(*both, R"(gpiochip0", GROUP="drivebusd")")) << *both;
    EXPECT_EQ(both->find("SUBSYSTEM==\"gpio\""), both->rfind("SUBSYSTEM==\"gpio\"")) << "one rule per chip";
    // The GPIO rules come before the tty section skips the rest.
    EXPECT_LT(both->find("SUBSYSTEM==\"gpio\""), both->find("SUBSYSTEM!=\"tty\"")) << *both;

    chip.properties["DEVPATH"] = "/devices/platform/soc/fe200000.gpio/gpiochip*";
    EXPECT_FALSE(rules_file(std::nullopt, {}, {chip}).has_value());
    chip.properties = sample("ttyAMA0");
    EXPECT_TRUE(has(rules_file(std::nullopt, {}, {chip}).error().message, "is not a GPIO chip"));
}

// What drivebusd --gpio-lines prints of a configuration (the program is run by UdevRuleCli).
TEST(UdevRule, GpioUsesComeFromWhatDrivebusdPrintsOfTheGpioBuses) {
    const auto uses = gpio_uses("line1\tgpiochip0\t17\nline2\tpinctrl-bcm2711 gpio\t4\n", "drivebusd.toml");
    ASSERT_TRUE(uses.has_value()) << uses.error().message;
    ASSERT_EQ(uses->size(), 2U);
    EXPECT_EQ(uses->front().bus, "line1");
    EXPECT_EQ(uses->front().chip, "gpiochip0");
    EXPECT_EQ(uses->front().line, 17);
    EXPECT_EQ(uses->back().chip, "pinctrl-bcm2711 gpio");
    EXPECT_EQ(uses->back().line, 4);

    const auto none = gpio_uses("", "sim.toml");
    ASSERT_FALSE(none.has_value());
    EXPECT_EQ(none.error().message, "sim.toml: no bus has direction = \"gpio\": no GPIO chip to give");
    for (const std::string_view wrong : {"line1 gpiochip0 17\n", "line1\tgpiochip0\n", "line1\tgpiochip0\t-1\n",
                                         "line1\tgpiochip0\t17x\n", "\tgpiochip0\t17\n", "line1\t\t17\n"}) {
        const auto refused = gpio_uses(wrong, "drivebusd.toml");
        ASSERT_FALSE(refused.has_value()) << wrong;
        EXPECT_EQ(refused.error().kind, RuleErrorKind::Usage);
        EXPECT_TRUE(has(refused.error().message, "not BUS, CHIP and LINE apart by tabs")) << refused.error().message;
    }
}

TEST(UdevRule, Helpers) {
    EXPECT_EQ(device_unit("rs485-0"), "dev-drivebus-rs485\\x2d0.device");
    EXPECT_EQ(device_unit("line1.a_b"), "dev-drivebus-line1.a_b.device");
    EXPECT_EQ(gpio_chip_devname("gpiochip2"), "gpiochip2");
    EXPECT_EQ(gpio_chip_devname("/dev/gpiochip2"), "gpiochip2");
    EXPECT_EQ(gpio_chip_devname("2"), "gpiochip2");
    EXPECT_EQ(gpio_chip_devname("pinctrl-bcm2711"), std::nullopt);
    EXPECT_EQ(gpio_chip_devname("gpiochip"), std::nullopt);

    const auto plain = parse_properties("P: /devices/x\nN: ttyS0\nE: DEVPATH=/devices/x\nE: SUBSYSTEM=tty\n\n");
    ASSERT_TRUE(plain.has_value()) << plain.error().message;
    EXPECT_EQ(plain->size(), 2U);
    EXPECT_EQ(plain->at("DEVPATH"), "/devices/x");
    const auto bad = parse_properties("DEVPATH=/devices/x\nnot a property\n");
    ASSERT_FALSE(bad.has_value());
    EXPECT_EQ(bad.error().kind, RuleErrorKind::Usage);
    EXPECT_TRUE(has(bad.error().message, "line 2")) << bad.error().message;
    EXPECT_FALSE(parse_properties("").has_value());
}

}  // namespace
}  // namespace drivebus::ctl::udev
