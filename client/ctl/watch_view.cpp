// SPDX-License-Identifier: Apache-2.0
// drivebusctl watch's screen and its JSON: the drives' key values, refreshed.
#include <string>
#include <vector>

#include "format.hpp"
#include "table.hpp"
#include "view.hpp"
#include "view_parts.hpp"

namespace drivebus::ctl {

using detail::info_of;
using detail::join;
using detail::line_text;
using detail::ms_text;
using detail::ms_value;

std::string key_values(const WatchDrive& d) {
    if (!d.snapshot) {
        return "no snapshot yet";
    }
    if (has_state(d.profile)) {
        return state_text(decode_state(*d.profile, *d.snapshot), *d.profile);
    }
    std::vector<std::string> parts;
    const auto& s = *d.snapshot;
    for (std::size_t i = 0; i < s.register_count && i < s.registers.size() && parts.size() < 4; ++i) {
        const auto& r = s.registers[i];
        const auto* info = info_of(d.profile, r.address);
        const auto name = info != nullptr ? info->name : hex(r.address);
        if (r.valid == 0) {
            parts.push_back(name + "=?");
            continue;
        }
        const auto value = info != nullptr ? format_engineering(*info, r.value) : std::string();
        parts.push_back(name + "=" + (value.empty() ? std::to_string(r.value) : value));
    }
    return parts.empty() ? std::string("no registers polled") : join(parts, " ");
}

std::vector<std::string> watch_lines(const shm::BusStatus& bus, const std::vector<WatchDrive>& drives,
                                     std::chrono::milliseconds interval, std::int64_t now_ns) {
    std::vector<std::string> lines;
    lines.push_back(fmt::format("drivebusctl watch: bus {} ({}), every {} ms; q quits", shm::view(bus.bus),
                                line_text(bus), interval.count()));
    lines.emplace_back();
    std::vector<Row> rows = {{"DRIVE", "ADDRESS", "PROFILE", "HEALTH", "AGE", "VALUES"}};
    for (const auto& d : drives) {
        rows.push_back({d.name, std::to_string(d.address), d.profile_type,
                        std::string(shm::to_string(d.snapshot ? d.snapshot->health : d.health)),
                        d.snapshot ? format_age(now_ns - d.snapshot->published_ns) : std::string("-"), key_values(d)});
    }
    const auto table = render_table(rows);
    std::size_t start = 0;
    for (auto end = table.find('\n'); end != std::string::npos; end = table.find('\n', start)) {
        lines.push_back(table.substr(start, end - start));
        start = end + 1;
    }
    lines.emplace_back();
    lines.push_back(fmt::format(
        "bus {}: {}, {} of {} drives online, {} replies, {} timeouts, reply latency {}", shm::view(bus.bus),
        bus.up != 0 ? "up" : "down", bus.drives_online, bus.drive_count, bus.counters.replies, bus.counters.timeouts,
        bus.reply_latency.count > 0 ? "mean " + ms_text(bus.reply_latency.mean_ns) : std::string("-")));
    return lines;
}

Json watch_json(const shm::BusStatus& bus, const std::vector<WatchDrive>& drives, std::int64_t now_ns) {
    auto out = Json::object();
    out.set("bus", Json::object()
                       .set("name", shm::view(bus.bus))
                       .set("up", bus.up != 0)
                       .set("drives_online", bus.drives_online)
                       .set("replies", bus.counters.replies)
                       .set("timeouts", bus.counters.timeouts)
                       .set("reply_latency_mean_ms", ms_value(bus.reply_latency.mean_ns)));
    auto list = Json::array();
    for (const auto& d : drives) {
        auto item = Json::object();
        item.set("name", d.name).set("address", d.address).set("profile", d.profile_type);
        item.set("health", shm::to_string(d.snapshot ? d.snapshot->health : d.health));
        item.set("age_ms", d.snapshot ? Json((now_ns - d.snapshot->published_ns) / 1'000'000) : Json());
        if (d.snapshot && has_state(d.profile)) {
            item.set("state", state_json(decode_state(*d.profile, *d.snapshot)));
        }
        auto values = Json::object();
        if (d.snapshot) {
            for (std::size_t i = 0; i < d.snapshot->register_count && i < d.snapshot->registers.size(); ++i) {
                const auto& r = d.snapshot->registers[i];
                const auto* info = info_of(d.profile, r.address);
                const auto name = info != nullptr ? info->name : hex(r.address);
                values.set(name, r.valid == 0                                ? Json()
                                 : info != nullptr && has_engineering(*info) ? Json(engineering(*info, r.value))
                                                                             : Json(r.value));
            }
        }
        item.set("values", std::move(values));
        list.push(std::move(item));
    }
    out.set("drives", std::move(list));
    return out;
}

}  // namespace drivebus::ctl
