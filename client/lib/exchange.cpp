// SPDX-License-Identifier: Apache-2.0
// A request's way through both deliveries: what the library fills in before it goes, and what
// it came to once answered or given up (the error kinds of client.hpp).
#include <unistd.h>

#include <cstring>

#include "bus_impl.hpp"

namespace drivebus {

bool send_request(iox::popo::UntypedClient& port, const shm::Request& request) {
    auto loaned = port.loan(sizeof(shm::Request), alignof(shm::Request));
    if (loaned.has_error()) {
        return false;
    }
    std::memcpy(loaned.value(), &request, sizeof request);
    return !port.send(loaned.value()).has_error();
}

Error Bus::Impl::not_permitted() const {
    std::string group;
    {
        std::lock_guard lock(mutex);  // the listener's thread writes the status
        group = status ? std::string(shm::view(status->control_group)) : std::string("drivebus-control");
    }
    return make_error(ErrorKind::NotPermitted, "requests on bus '" + name + "' need membership of group " + group +
                                                   " (usermod -aG " + group + " $USER); watching needs none");
}

bool Bus::Impl::prepare(shm::Request& request) {
    request.version = shm::kPayloadVersion;
    request.size = sizeof(shm::Request);
    if (request.client == 0) {
        request.client = client_id;
    }
    if (shm::view(request.client_name).empty()) {
        shm::assign(request.client_name, client_name);
    }
    if (request.pid == 0) {
        request.pid = static_cast<std::int32_t>(::getpid());
    }
    // Past this time the caller has given up: drivebusd drops the request rather than send it.
    // A deadline of the caller's own that comes sooner stays, and its expiry is told apart.
    const auto given_up = monotonic_ns(Clock::now() + options.request_timeout);
    const bool own_deadline = request.deadline_ns != 0 && request.deadline_ns <= given_up;
    if (!own_deadline && request.kind != shm::RequestKind::Withdraw) {
        request.deadline_ns = given_up;
    }
    std::lock_guard lock(mutex);
    if (request.lease_token == shm::LeaseToken{}) {
        const auto it = lease_tokens.find(shm::view(request.drive));
        request.lease_token = it != lease_tokens.end() ? it->second : latest_token;
    }
    request.correlation = next_correlation++;
    waiting.emplace(request.correlation, Pending{});
    return own_deadline;
}

std::expected<shm::Response, Error> Bus::Impl::conclude(const shm::Request& request, bool own_deadline, bool answered) {
    auto response = waiting.at(request.correlation).response;
    const auto handed = waiting.at(request.correlation).handed;
    waiting.erase(request.correlation);
    if (response && response->status == shm::Status::Rejected && response->reason == shm::RejectReason::NotPending) {
        response.reset();  // drivebusd holds no such request: its answer was lost, or it never came
        answered = false;
    }
    if (response && response->status == shm::Status::Expired && !own_deadline) {
        response->status = shm::Status::Withdrawn;  // dropped at this library's time-out, not the caller's deadline
    }
    if (response && response->lease_ms > 0 && response->lease_token != shm::LeaseToken{}) {
        // This request took a lease: its token from now on.
        lease_tokens[std::string(shm::view(request.drive))] = response->lease_token;
        latest_token = response->lease_token;
    }
    if (!answered && handed == Handed::Not) {
        return std::unexpected(make_error(
            ErrorKind::NoReply, "iceoryx has not let the request go within " +
                                    std::to_string(options.request_timeout.count()) +
                                    " ms (a client killed while sending may hold its lock): the outcome is unknown "
                                    "(read the register back)"));
    }
    if (!answered || !response) {
        const bool gone = !(status.has_value() && Clock::now() - status_time < options.daemon_silence);
        return std::unexpected(
            gone ? make_error(ErrorKind::DaemonGone, "drivebusd has gone silent (no bus status for " +
                                                         std::to_string(options.daemon_silence.count()) + " ms)")
                 : make_error(ErrorKind::NoReply, "drivebusd did not answer within " +
                                                      std::to_string(options.request_timeout.count()) +
                                                      " ms, nor its withdrawal: the outcome is "
                                                      "unknown (read the register back)"));
    }
    return *response;
}

}  // namespace drivebus
