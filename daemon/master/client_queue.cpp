// SPDX-License-Identifier: Apache-2.0
// The scheduler's client side: per-client queues (writes and reads apart, served
// round-robin) under the queue limit, and the lease fallbacks' slots, one per drive, ahead of
// every client queue and outside the limit. Pure.
#include <algorithm>

#include "master/scheduler.hpp"

namespace drivebus::master {

std::expected<void, SubmitError> Scheduler::submit(ClientRequest request) {
    Job job;
    job.kind = JobKind::Client;
    job.client = request.client;
    job.correlation = request.correlation;
    job.request = request.request;
    job.deadline = request.deadline;
    if (request.request.address == rtu::kBroadcastAddress) {
        job.drive = kNoDrive;
    } else if (request.probe) {
        job.drive = kNoDrive;  // no drive's counters or health: it may not be configured
        job.retries = 0;
    } else if (const auto d = drive_at(request.request.address)) {
        job.drive = *d;
    } else {
        return std::unexpected(SubmitError::UnknownDrive);
    }
    if (request.fallback) {
        if (job.drive == kNoDrive) {
            return std::unexpected(SubmitError::UnknownDrive);
        }
        if (drives_[job.drive].fallback) {
            return std::unexpected(SubmitError::QueueFull);
        }
        job.fallback = true;
        drives_[job.drive].fallback = std::move(job);
        return {};
    }
    if (job.drive != kNoDrive && !drives_[job.drive].blocks_confirmed && through_block(job.drive, job.request)) {
        return std::unexpected(SubmitError::BlockUnconfirmed);
    }
    if (queued_ >= bus_.queue_limit) {
        return std::unexpected(SubmitError::QueueFull);
    }
    const bool write = !std::holds_alternative<rtu::ReadHoldingRegisters>(request.request.pdu) &&
                       !std::holds_alternative<rtu::ReadDeviceIdentification>(request.request.pdu);
    (write ? writes_ : reads_)[request.client].push_back(std::move(job));
    ++queued_;
    return {};
}

std::optional<Job> Scheduler::next_client_read() {
    return take_client({&reads_});
}

std::optional<Job> Scheduler::take_client(std::initializer_list<std::map<std::uint64_t, std::deque<Job>>*> order) {
    for (auto* queues : order) {
        if (queues->empty()) {
            continue;
        }
        // Round-robin: the first client after the one served last.
        auto it = queues->upper_bound(last_client_);
        if (it == queues->end()) {
            it = queues->begin();
        }
        Job job = std::move(it->second.front());
        it->second.pop_front();
        last_client_ = it->first;
        if (it->second.empty()) {
            queues->erase(it);
        }
        --queued_;
        return job;
    }
    return std::nullopt;
}

std::optional<Job> Scheduler::next_fallback() {
    for (Drive& drive : drives_) {
        if (drive.fallback) {
            return std::exchange(drive.fallback, std::nullopt);
        }
    }
    return std::nullopt;
}

bool Scheduler::withdraw(std::uint64_t correlation) {
    for (auto* queues : {&writes_, &reads_}) {
        for (auto it = queues->begin(); it != queues->end(); ++it) {
            auto& queue = it->second;
            const auto job = std::ranges::find(queue, correlation, &Job::correlation);
            if (job == queue.end()) {
                continue;
            }
            queue.erase(job);
            if (queue.empty()) {
                queues->erase(it);
            }
            --queued_;
            return true;
        }
    }
    return false;
}

const std::vector<Job>& Scheduler::expire(rtu::Instant now) {
    expired_.clear();
    for (auto* queues : {&writes_, &reads_}) {
        for (auto it = queues->begin(); it != queues->end();) {
            auto& queue = it->second;
            const auto gone = std::ranges::remove_if(queue, [&](const Job& job) {
                if (!job.deadline || *job.deadline > now) {
                    return false;
                }
                expired_.push_back(job);
                return true;
            });
            queued_ -= static_cast<std::size_t>(gone.size());
            queue.erase(gone.begin(), gone.end());
            it = queue.empty() ? queues->erase(it) : std::next(it);
        }
    }
    return expired_;
}

std::optional<rtu::Instant> Scheduler::next_deadline() const {
    std::optional<rtu::Instant> next;
    for (const auto* queues : {&writes_, &reads_}) {
        for (const auto& [client, queue] : *queues) {
            for (const Job& job : queue) {
                if (job.deadline && (!next || *job.deadline < *next)) {
                    next = job.deadline;
                }
            }
        }
    }
    return next;
}

std::vector<Job> Scheduler::take_client_jobs() {
    std::vector<Job> jobs;
    for (auto* queues : {&writes_, &reads_}) {
        for (auto& [client, queue] : *queues) {
            jobs.insert(jobs.end(), queue.begin(), queue.end());
        }
        queues->clear();
    }
    queued_ = 0;
    return jobs;
}

}  // namespace drivebus::master
