// SPDX-License-Identifier: Apache-2.0
// drivebusd's place in iceoryx: finds or embeds RouDi, lays out the shared memory so that Unix
// groups decide who may watch and who may send requests, and starts this process's runtime.
#pragma once

#include <cstdint>
#include <expected>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "config/config.hpp"

namespace drivebus::ipc {

struct MemPool {
    std::uint32_t size = 0;  // chunk payload bytes
    std::uint32_t count = 0;
};

struct Segment {
    std::string reader_group;
    std::string writer_group;
    std::vector<MemPool> pools;
};

struct Layout {
    // True: the three groups exist and the segments keep watchers, controllers and drivebusd
    // apart. False: none of them exists; one segment for this process's group (no control).
    bool grouped = false;
    std::vector<Segment> segments;
    std::string control_group;  // announced to clients; empty when not grouped
};

// The segments for this configuration, sized for its drives and max_clients. Fails when only
// some of the groups exist, or when this process's user is not in daemon_group.
[[nodiscard]] std::expected<Layout, std::string> plan_layout(const config::Config& config);

// Why shared memory laid out as `running` cannot hold what `needed` asks for (a reload that
// adds buses or drives, or clients), one line; nullopt when it can.
[[nodiscard]] std::optional<std::string> layout_shortfall(const Layout& running, const Layout& needed);

// Whether a RouDi answers on its socket (/tmp/roudi).
[[nodiscard]] bool roudi_running();

class Host {
public:
    // Embeds or joins RouDi as `roudi` says, then starts the runtime named `name`.
    static std::expected<std::unique_ptr<Host>, std::string> start(const config::Config& config,
                                                                   const std::string& name);
    ~Host();
    Host(const Host&) = delete;
    Host& operator=(const Host&) = delete;
    Host(Host&&) = delete;
    Host& operator=(Host&&) = delete;

    [[nodiscard]] bool embedded() const noexcept;
    [[nodiscard]] const Layout& layout() const noexcept { return layout_; }
    // The file of iceoryx's management segment (/dev/shm/iceoryx_mgmt): RouDi's bookkeeping,
    // hundreds of MiB mapped whether embedded or not, which drivebusd's threads do not need
    // locked in memory.
    [[nodiscard]] static std::string management_segment();
    // One line for the log: "embedded RouDi, 2 segments (8.4 MiB), groups drivebus/drivebus-control".
    [[nodiscard]] std::string describe() const;
    // What start() could not do and drivebusd runs without, one line each, for the log.
    [[nodiscard]] const std::vector<std::string>& warnings() const noexcept { return warnings_; }
    // What start() tidied up on the way, one line each, for the log.
    [[nodiscard]] const std::vector<std::string>& notes() const noexcept { return notes_; }

private:
    struct Embedded;
    Host() = default;
    Layout layout_;
    std::vector<std::string> warnings_;
    std::vector<std::string> notes_;
    std::unique_ptr<Embedded> roudi_;
};

}  // namespace drivebus::ipc
