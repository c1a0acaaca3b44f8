// SPDX-License-Identifier: Apache-2.0
#include "commands.hpp"

#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <functional>

#include "format.hpp"
#include "json.hpp"
#include "steps.hpp"
#include "table.hpp"
#include "view.hpp"

namespace drivebus::ctl {

Error error_of(ErrorKind kind, std::string message) {
    Error e;
    e.kind = kind;
    e.message = std::move(message);
    return e;
}

Bus connect(const Options& options) {
    return need(Bus::connect(options.bus, connect_options(options)), options);
}

Error response_error(const shm::Response& r) {
    switch (r.status) {
    case shm::Status::Rejected: {
        auto e =
            error_of(ErrorKind::Rejected, fmt::format("drivebusd rejected the probe: {}", shm::to_string(r.reason)));
        e.reason = r.reason;
        return e;
    }
    case shm::Status::QueueFull:
        return error_of(ErrorKind::QueueFull, "the bus's request queue is full; try again shortly");
    case shm::Status::BusDown:
        return error_of(ErrorKind::BusDown,
                        "the bus is down: its serial device is not open (see journalctl -u drivebusd)");
    case shm::Status::NotPermitted:
        return error_of(ErrorKind::NotPermitted, "drivebusd does not let this client send requests");
    default: return error_of(ErrorKind::BadFrame, fmt::format("unexpected answer: {}", shm::to_string(r.status)));
    }
}

void fail_request(const Options& options, Error error, const Drive& drive, std::string_view what, std::uint16_t start,
                  std::size_t count, const std::string& context) {
    const auto hint = rejection_hint(error, drive.profile(), what, start, count);
    if (!hint.empty()) {
        error.message += "; " + hint;
    }
    throw Failed{report(options, error, context)};
}

int guarded(const std::function<int()>& body) {
    try {
        return body();
    } catch (const Failed& f) {
        return f.status;
    }
}

namespace {

std::string register_lines(const Drive& drive, std::uint16_t start, const std::vector<std::uint16_t>& values) {
    std::vector<Row> rows;
    std::vector<std::vector<std::string>> bits;
    for (std::size_t i = 0; i < values.size(); ++i) {
        const auto address = static_cast<std::uint16_t>(start + i);
        const auto* info = drive.info(address);
        rows.push_back(register_columns(address, values[i], info));
        bits.push_back(info != nullptr ? set_bits(*info, values[i]) : std::vector<std::string>{});
    }
    // No column of engineering values when no register has one.
    if (std::ranges::all_of(rows, [](const Row& row) { return row[3].empty(); })) {
        for (auto& row : rows) {
            row.erase(row.begin() + 3);
        }
    }
    // The table aligned as a whole, then each register's bits under it.
    const auto table = render_table(rows);
    std::string out;
    std::size_t line_start = 0;
    for (std::size_t i = 0; i < rows.size(); ++i) {
        const auto end = table.find('\n', line_start);
        out += table.substr(line_start, end - line_start + 1);
        line_start = end + 1;
        for (const auto& b : bits[i]) {
            out += "    bit " + b + "\n";
        }
    }
    return out;
}

Json registers_json(const Drive& drive, std::uint16_t start, const std::vector<std::uint16_t>& values) {
    auto list = Json::array();
    for (std::size_t i = 0; i < values.size(); ++i) {
        const auto address = static_cast<std::uint16_t>(start + i);
        list.push(register_json(address, values[i], drive.info(address)));
    }
    return list;
}

// Which of the words written have no unit in the profile: they went as given, raw, and the
// user should know that nothing was converted.
std::string raw_note(const Drive& drive, std::uint16_t start, std::size_t count) {
    std::string names;
    for (std::size_t i = 0; i < count; ++i) {
        const auto address = static_cast<std::uint16_t>(start + i);
        const auto* info = drive.info(address);
        if (info == nullptr || info->unit.empty()) {
            names += (names.empty() ? "" : ", ") + (info != nullptr ? info->name : hex(address));
        }
    }
    if (names.empty()) {
        return {};
    }
    const auto* profile = drive.profile();
    const bool one = names.find(',') == std::string::npos;
    return fmt::format("raw word{} written as given: {} {} no unit in the {} profile\n", one ? "" : "s", names,
                       one ? "has" : "have", profile != nullptr ? profile->type : std::string("drive's"));
}

}  // namespace

int report(const Options& options, const Error& error, const std::string& context) {
    auto message = context.empty() ? error.message : context + ": " + error.message;
    std::ranges::replace(message, '\n', ' ');
    std::fflush(stdout);
    std::fprintf(stderr, "drivebusctl: %s\n", message.c_str());
    if (options.json) {
        print(Json::object()
                  .set("error", Json::object().set("kind", kind_name(error.kind)).set("message", message))
                  .dump());
    }
    return exit_code(error.kind);
}

void print(const std::string& text) {
    std::fwrite(text.data(), 1, text.size(), stdout);
    if (text.empty() || text.back() != '\n') {
        std::fputc('\n', stdout);
    }
    std::fflush(stdout);
}

ConnectOptions connect_options(const Options& options) {
    ConnectOptions c;
    c.application = "drivebusctl";
    c.request_timeout = options.timeout;
    if (!options.profile_dir.empty()) {
        c.profile_dir = options.profile_dir;
    }
    return c;
}

int run_list(const Options& options) {
    return guarded([&] {
        std::vector<std::string> names;
        if (options.bus.empty()) {
            names = need(Bus::list(connect_options(options)), options);
        } else {
            names = {options.bus};
        }
        auto buses = Json::array();
        std::string text;
        for (const auto& name : names) {
            const auto bus = need(Bus::connect(name, connect_options(options)), options);
            const auto status = need(bus.status(kFirstData), options);
            buses.push(Json::object()
                           .set("name", name)
                           .set("up", status.up != 0)
                           .set("device", shm::view(status.device))
                           .set("baud", status.baud)
                           .set("format", shm::view(status.format))
                           .set("drives_online", status.drives_online)
                           .set("drive_count", status.drive_count)
                           .set("drives", drives_json(status)));
            text += fmt::format("bus {}: {}, {} {} {}, {} of {} drives online\n", name, status.up != 0 ? "up" : "down",
                                shm::view(status.device), status.baud, shm::view(status.format), status.drives_online,
                                status.drive_count);
            text += render_table(drive_rows(status), "  ");
        }
        if (names.empty()) {
            text = "drivebusd announces no bus\n";
        }
        print(options.json ? Json::object().set("buses", std::move(buses)).dump() : text);
        return kExitOk;
    });
}

int run_status(const Options& options, const std::string& drive_name) {
    return guarded([&] {
        const auto bus = connect(options);
        if (drive_name.empty()) {
            const auto status = need(bus.status(kFirstData), options);
            const auto now = monotonic_ns();
            print(options.json ? bus_status_json(status, bus.can_request(), now).dump()
                               : bus_status_text(status, bus.can_request(), now));
            return kExitOk;
        }
        const auto drive = need(bus.drive(drive_name), options, "status " + drive_name);
        const auto snapshot = need(drive.wait_snapshot(kFirstData), options, "status " + drive_name);
        const auto now = monotonic_ns();
        print(options.json ? drive_status_json(snapshot, drive.profile(), now).dump()
                           : drive_status_text(snapshot, drive.profile(), now));
        return kExitOk;
    });
}

int run_read(const Options& options, const std::string& drive_name, const std::string& reg, std::uint16_t count) {
    return guarded([&] {
        const auto context = fmt::format("read {} {}", drive_name, reg);
        const auto bus = connect(options);
        const auto drive = need(bus.drive(drive_name), options, context);
        const auto start = need(drive.resolve(reg), options, context);
        std::vector<std::uint16_t> values;
        std::string source = "bus";
        std::int64_t snapshot_age = 0;
        if (!bus.can_request() && count >= 1) {
            // Watching only: what the latest snapshot holds may do.
            if (auto s = drive.wait_snapshot(kFirstData)) {
                for (std::uint16_t i = 0; i < count; ++i) {
                    const auto* sample = s->find(static_cast<std::uint16_t>(start + i));
                    if (sample == nullptr || sample->valid == 0) {
                        values.clear();
                        break;
                    }
                    values.push_back(sample->value);
                }
                if (!values.empty()) {
                    source = "snapshot";
                    snapshot_age = monotonic_ns() - s->published_ns;
                    const auto status = need(bus.status(), options);
                    std::fflush(stdout);
                    std::fprintf(stderr, "drivebusctl: from the snapshot of %s ago: requests need group %s\n",
                                 format_age(snapshot_age).c_str(),
                                 std::string(shm::view(status.control_group)).c_str());
                }
            }
        }
        if (values.empty()) {
            auto result = drive.read(start, count);
            if (!result) {
                fail_request(options, result.error(), drive, "read", start, count, context);
            }
            values = std::move(*result);
        }
        if (options.json) {
            auto doc = Json::object()
                           .set("bus", bus.name())
                           .set("drive", drive.name())
                           .set("address", drive.address())
                           .set("source", source)
                           .set("registers", registers_json(drive, start, values));
            if (source == "snapshot") {
                doc.set("age_ms", snapshot_age / 1'000'000);
            }
            print(doc.dump());
        } else {
            print(register_lines(drive, start, values));
        }
        return kExitOk;
    });
}

int run_write(const Options& options, const std::string& drive_name, const std::string& reg,
              const std::vector<std::string>& value_args, const WriteOptions& write_options) {
    return guarded([&] {
        const auto context = fmt::format("write {} {}", drive_name, reg);
        const auto bus = connect(options);
        const auto drive = need(bus.drive(drive_name), options, context);
        const auto start = need(drive.resolve(reg), options, context);
        const auto texts = join_units(value_args);
        if (texts.empty() || texts.size() > shm::kMaxWriteWords) {
            throw Failed{report(options, error_of(ErrorKind::InvalidArgument, "a write takes 1-123 values"), context)};
        }
        if (static_cast<std::size_t>(start) + texts.size() - 1 > 0xFFFF) {
            throw Failed{
                report(options, error_of(ErrorKind::InvalidArgument, "the values run past register 0xFFFF"), context)};
        }
        std::vector<std::uint16_t> words;
        for (std::size_t i = 0; i < texts.size(); ++i) {
            const auto* info = drive.info(static_cast<std::uint16_t>(start + i));
            auto word = parse_value(texts[i], info);
            if (!word) {
                throw Failed{report(options, error_of(ErrorKind::InvalidArgument, word.error()), context)};
            }
            words.push_back(*word);
        }
        const auto written = drive.write(start, words, write_options);
        // A write that reached the command or reference, directly or through an indirect block,
        // took the control lease, and drivebusd's answer (its result, or the drive's failure to
        // answer) handed this process its token: give the lease back, or drivebusd would apply the
        // fallback once this process stops renewing it. A refused write took nothing.
        bool released = false;
        if (drive.holds_control()) {
            released = drive.release_control().has_value();
            if (released) {
                std::fflush(stdout);
                std::fprintf(stderr,
                             "drivebusctl: released the control lease of drive '%s' (no fallback; the values written "
                             "stay in force)\n",
                             drive.name().c_str());
            }
        }
        if (!written) {
            fail_request(options, written.error(), drive, "write", start, words.size(), context);
        }
        if (options.json) {
            print(Json::object()
                      .set("bus", bus.name())
                      .set("drive", drive.name())
                      .set("address", drive.address())
                      .set("function", words.size() == 1 ? 6 : 16)
                      .set("written", registers_json(drive, start, words))
                      .set("lease_released", released)
                      .dump());
        } else {
            print(fmt::format("wrote to drive '{}':\n", drive.name()) + register_lines(drive, start, words) +
                  raw_note(drive, start, words.size()));
        }
        return kExitOk;
    });
}

}  // namespace drivebus::ctl
