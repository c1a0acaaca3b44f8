// SPDX-License-Identifier: Apache-2.0
// The scheduler's set-up side: the selectors of each drive's indirect blocks written and read
// back, the read block confirmed (master/setup_plan), the drive unconfigured or awaiting a
// reset until it holds, requests through a block refused until then, and the set-up run again
// when the drive's fault clears. Pure.
#include <algorithm>

#include "master/scheduler.hpp"

namespace drivebus::master {

std::optional<Job> Scheduler::next_setup(rtu::Instant now) {
    for (std::size_t d = 0; d < drives_.size(); ++d) {
        Drive& drive = drives_[d];
        if (drive.setup_done || drive.health == Health::Absent || now < drive.setup_retry) {
            continue;
        }
        const auto request = drive.setup.next();
        if (!request) {
            continue;
        }
        Job job;
        job.kind = JobKind::Setup;
        job.drive = d;
        job.request = *request;
        return job;
    }
    return std::nullopt;
}

// The drive's own Modbus time-out, read (and written when configured) once it has answered:
// after its set-up, before its polls; it holds nothing back. A drive nothing has reached yet
// gets no request for it (one with nothing polled hears only what clients ask).
std::optional<Job> Scheduler::next_check() {
    for (std::size_t d = 0; d < drives_.size(); ++d) {
        Drive& drive = drives_[d];
        if (drive.health == Health::Absent || drive.health == Health::Unknown) {
            continue;
        }
        if (const auto request = drive.comm.next()) {
            Job job;
            job.kind = JobKind::Check;
            job.drive = d;
            job.request = *request;
            return job;
        }
    }
    return std::nullopt;
}

std::optional<std::size_t> Scheduler::check_step(const Job& job, const Result& result) {
    Drive& drive = drives_[job.drive];
    if (result.outcome == Outcome::BusDown) {
        drive.comm.restart();
        return std::nullopt;
    }
    if (!drive.comm.take(result) || !drive.groups.empty()) {
        return std::nullopt;  // its next poll cycle publishes the note (a snapshot before it would hold no values)
    }
    ++drive.sequence;  // nothing polls it: published now
    return job.drive;
}

void Scheduler::setup_failed(std::size_t drive, rtu::Instant now, SetupState state) {
    Drive& d = drives_[drive];
    d.health = state == SetupState::AwaitingReset ? Health::AwaitingReset : Health::Unconfigured;
    d.setup_done = false;
    d.blocks_confirmed = false;
    d.setup.restart();
    d.setup_backoff =
        d.setup_backoff.count() == 0 ? bus_.absent_backoff_min : std::min(d.setup_backoff * 2, bus_.absent_backoff_max);
    d.setup_retry = now + d.setup_backoff;
    for (auto& [address, value] : d.values) {
        value.valid = false;
    }
    for (Group& g : d.groups) {
        g.cursor.reset();
    }
}

std::optional<std::size_t> Scheduler::setup_step(const Job& job, const Result& result, rtu::Instant now) {
    Drive& drive = drives_[job.drive];
    if (result.outcome == Outcome::BusDown) {
        drive.setup.restart();  // the line went down: set up again from the start once it is back
        return std::nullopt;
    }
    const Health before = drive.health;
    switch (drive.setup.take(result)) {
    case SetupState::Running: return std::nullopt;
    case SetupState::Done:
        drive.setup_done = true;
        drive.blocks_confirmed = true;
        drive.setup_backoff = {};
        if (drive.health == Health::Unconfigured || drive.health == Health::AwaitingReset) {
            drive.health = Health::Online;
        }
        break;
    case SetupState::Failed:
    case SetupState::AwaitingReset: setup_failed(job.drive, now, drive.setup.state()); break;
    }
    if (drive.health != before) {
        ++drive.sequence;
        return job.drive;
    }
    return std::nullopt;
}

bool Scheduler::through_block(std::size_t drive, const rtu::RequestAdu& request) const noexcept {
    const Profile& profile = *drives_[drive].config->profile;
    const auto at = [&](std::uint8_t function, std::uint16_t start, std::size_t count) {
        const IndirectBlock* block = profile.block(function);
        return block != nullptr && start == block->address && count >= block->min_quantity &&
               count <= block->max_quantity;
    };
    if (const auto* r = std::get_if<rtu::ReadHoldingRegisters>(&request.pdu)) {
        return at(3, r->start, r->quantity);
    }
    if (const auto* w = std::get_if<rtu::WriteMultipleRegisters>(&request.pdu)) {
        return at(16, w->start, w->values.size());
    }
    if (const auto* w = std::get_if<rtu::WriteSingleRegister>(&request.pdu)) {
        return at(16, w->address, 1);
    }
    return false;
}

// A drive whose fault is cleared has been reset: what it applies after a reset (the ATV21's
// block selectors) may have changed, so its blocks are confirmed again.
void Scheduler::watch_fault(std::size_t drive, const ReadChunk& chunk, const Result& result) {
    Drive& d = drives_[drive];
    if (!d.fault_flag) {
        return;
    }
    const auto* words = result.response ? std::get_if<rtu::ReadHoldingRegistersResponse>(&*result.response) : nullptr;
    if (words == nullptr) {
        return;
    }
    for (std::size_t i = 0; i < chunk.addresses.size() && i < words->values.size(); ++i) {
        if (chunk.addresses[i] != d.fault_flag->status) {
            continue;
        }
        const bool faulted = ((static_cast<unsigned>(words->values[i]) >> d.fault_flag->bit) & 1U) != 0;
        if (d.faulted && !faulted && d.setup_done) {
            d.setup.reset_seen();
            d.setup.restart();
            d.setup_done = false;
        }
        d.faulted = faulted;
    }
}

}  // namespace drivebus::master
