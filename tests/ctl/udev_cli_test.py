#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""drivebusctl udev-rule as a program: on the property samples of tests/ctl/udev/, its exit
status, stdout and stderr, and every file it prints through the deploy rule checker
(tests/deploy/check_udev_rules.py). No RouDi runs and no drivebusd stays: --config FILE is read
by `drivebusd --config FILE --gpio-lines` (DRIVEBUSD names the build's), which opens nothing.

The example udev/60-drivebus-rs485-0.rules.example must be, after its first comment
lines, what the program prints for the FT232R sample.

usage: udev_cli_test.py DRIVEBUSCTL DRIVEBUSD CHECK_UDEV_RULES SAMPLES_DIR EXAMPLES_DIR RULES_EXAMPLE
"""
import os
import shutil
import subprocess
import sys
import tempfile

failures = []


def run(ctl, *args, drivebusd=None):
    env = dict(os.environ)
    if drivebusd is not None:
        env["DRIVEBUSD"] = drivebusd
    return subprocess.run([ctl, "udev-rule", *args], capture_output=True, text=True, timeout=30, check=False,
                          env=env, stdin=subprocess.DEVNULL)


def expect(cond, what):
    if not cond:
        failures.append(what)
        print(f"FAIL: {what}")


def main(argv):
    if len(argv) != 7:
        sys.exit(__doc__)
    ctl, drivebusd, checker, samples, examples, rules_example = argv[1:]
    tmp = tempfile.mkdtemp(prefix="drivebus-udev-")
    # A GPIO bus in a fragment (drivebusd.d/*.toml) beside a file that has none: drivebusd reads both.
    fragmented = os.path.join(tmp, "drivebusd.toml")
    with open(fragmented, "w", encoding="utf-8") as f:
        f.write('[[bus]]\nname = "line1"\ndevice = "/dev/ttyS1"\n'
                '  [[bus.drive]]\n  name = "pump"\n  address = 1\n  profile = "atv21"\n')
    os.mkdir(os.path.join(tmp, "drivebusd.d"))
    with open(os.path.join(tmp, "drivebusd.d", "line2.toml"), "w", encoding="utf-8") as f:
        f.write('[[bus]]\nname = "line2"\ndevice = "/dev/ttyS2"\ndirection = "gpio"\n'
                'gpio_chip = "gpiochip0"\ngpio_line = 5\n'
                '  [[bus.drive]]\n  name = "fan"\n  address = 2\n  profile = "atv21"\n')
    # One drivebusd refuses.
    refused_config = os.path.join(tmp, "refused.toml")
    with open(refused_config, "w", encoding="utf-8") as f:
        f.write('[[bus]]\nname = "line1"\ndevice = "/dev/ttyS1"\ndirection = "gpio"\n'
                'gpio_chip = "gpiochip0"\ngpio_line = 5000\n'
                '  [[bus.drive]]\n  name = "pump"\n  address = 1\n  profile = "atv21"\n')
    s = lambda name: os.path.join(samples, name + ".properties")  # noqa: E731

    # Accepted: (arguments, parts stdout must hold).
    accepted = [
        ([ "--properties", s("ft232r")], ['ENV{ID_SERIAL_SHORT}=="A10KXYZ1"', 'ATTR{device/latency_timer}="1"',
                                          "# /etc/udev/rules.d/60-drivebus-rs485-0.rules"]),
        (["--properties", s("ft4232-port1"), "--name", "line2"], ['ENV{ID_USB_INTERFACE_NUM}=="01"',
                                                                   'SYMLINK+="drivebus/line2"']),
        (["--properties", s("cp2102")], ['ENV{ID_MODEL_ID}=="ea60"']),
        (["--properties", s("cp2102-clone"), "--by-path"], ['ENV{ID_PATH}=="pci-0000:00:14.0-usb-0:3:1.0"']),
        (["--properties", s("ch340"), "--by-path", "--start", "drivebusd@line1.service"],
         ['ENV{SYSTEMD_WANTS}+="drivebusd@line1.service"', 'ENV{ID_MODEL_ID}=="7523"']),
        (["--properties", s("pl2303"), "--by-path", "--group", "drivebus"], ['GROUP="drivebus"']),
        (["--properties", s("cdc-acm")], ['ENV{ID_SERIAL_SHORT}=="205E37A25748"']),
        (["--properties", s("ttyAMA0")], ['DEVPATH=="/devices/platform/soc/fe201000.serial/tty/ttyAMA0"']),
        (["--properties", s("ttyS1")], ['ATTR{rx_trig_bytes}="1"']),
        (["--properties", s("gpiochip0")], ['SUBSYSTEM=="gpio", DEVPATH=="/devices/platform/soc/fe200000.gpio/gpiochip0", '
                                            'GROUP="drivebusd", MODE="0660"', "60-drivebus-gpio.rules"]),
        (["--properties", s("ft232r"), "--properties", s("gpiochip0"), "--config", os.path.join(examples, "gpio.toml")],
         ["bus 'line1' drives its transceiver's enable on line 17", 'GROUP="drivebusd", MODE="0660"',
          'SYMLINK+="drivebus/rs485-0"']),
        (["--properties", s("gpiochip0"), "--config", fragmented],
         ["bus 'line2' drives its transceiver's enable on line 5", 'GROUP="drivebusd", MODE="0660"']),
    ]
    with tempfile.TemporaryDirectory() as rules:
        for i, (args, parts) in enumerate(accepted):
            p = run(ctl, *args, drivebusd=drivebusd)
            what = " ".join(os.path.basename(a) for a in args)
            expect(p.returncode == 0, f"{what}: exit {p.returncode}, stderr {p.stderr!r}")
            expect(p.stderr == "", f"{what}: stderr {p.stderr!r}")
            for part in parts:
                expect(part in p.stdout, f"{what}: no {part!r} in the output")
            expect("KERNEL" not in p.stdout, f"{what}: a kernel name match")
            if "--start" not in args:
                expect("SYSTEMD_WANTS" not in p.stdout, f"{what}: SYSTEMD_WANTS without --start")
            path = os.path.join(rules, f"{i}.rules")
            with open(path, "w", encoding="utf-8") as f:
                f.write(p.stdout)
            c = subprocess.run([sys.executable, checker, path], capture_output=True, text=True, check=False)
            expect(c.returncode == 0, f"{what}: the rule checker says: {c.stdout.strip()}")

    # Refused or wrong: (arguments, exit status, part of the one line on stderr[, DRIVEBUSD]).
    refused = [
        (["--properties", s("gpiochip0"), "--config", refused_config], 2,
         f"{refused_config}: bus 'line1': gpio_line 5000 is above 1023"),
        (["--properties", s("gpiochip0"), "--config", os.path.join(examples, "sim.toml")], 2,
         'no bus has direction = "gpio"'),
        (["--properties", s("gpiochip0"), "--config", fragmented], 5, "cannot run /nonexistent/drivebusd",
         "/nonexistent/drivebusd"),
        (["--properties", s("ch340")], 3, "has no serial number"),
        (["--properties", s("pl2303")], 3, "run again with --by-path"),
        (["--properties", s("cp2102-clone")], 3, "which many adapters of its kind share"),
        (["--properties", s("kernel-name-only")], 3, "has no DEVPATH"),
        (["--properties", s("hostile-serial")], 3, "contains '\"'"),
        (["--properties", s("ft232r"), "--name", "Bad Name"], 2, "--name"),
        (["--properties", s("ft232r"), "--start", "drivebusd@.service"], 2, "--start"),
        (["--properties", s("ft232r"), "--properties", s("cp2102")], 2, "a second serial port"),
        (["--properties", s("gpiochip0"), "--gpio-chip", "pinctrl-bcm2711"], 5, "name the chip gpiochipN"),
        (["--properties", os.path.join(samples, "missing.properties")], 5, "missing.properties"),
        (["--properties", os.path.join(examples, "gpio.toml")], 2, "is not KEY=VALUE"),
        ([], 2, "name a DEVICE"),
        (["--no-such-option"], 2, ""),
        # Through sd-device: a device that is not a serial port, and one that does not exist.
        (["/dev/null"], 3, "is not a serial port"),
        (["/dev/ttyDRIVEBUSNONE"], 5, "/dev/ttyDRIVEBUSNONE"),
    ]
    for args, status, part, *program in refused:
        p = run(ctl, *args, drivebusd=program[0] if program else drivebusd)
        what = " ".join(os.path.basename(a) for a in args) or "(no arguments)"
        expect(p.returncode == status, f"{what}: exit {p.returncode}, not {status}; stderr {p.stderr!r}")
        expect(p.stdout == "", f"{what}: stdout {p.stdout!r}")
        lines = p.stderr.splitlines()
        expect(len(lines) == 1 and lines[0].startswith("drivebusctl: ") and part in lines[0],
               f"{what}: stderr {p.stderr!r} is not one line with {part!r}")

    with open(rules_example, encoding="utf-8") as f:
        example = f.read()
    generated = run(ctl, "--properties", s("ft232r")).stdout
    head = example.split("\n# /etc/udev/rules.d/", 1)[0]
    expect(example == head + "\n" + generated,
           f"{rules_example} is not the output for ft232r.properties after its {head.count(chr(10)) + 1} first lines")

    shutil.rmtree(tmp)
    print(f"udev-rule: {len(accepted)} accepted, {len(refused)} refused; "
          f"{'OK' if not failures else f'{len(failures)} failure(s)'}")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
