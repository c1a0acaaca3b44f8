// Asks iceoryx directly, without libdrivebus and its group check, for a request chunk on a
// bus's request server and sends one write (pump's FA51 = VALUE):
//   raw_request BUS VALUE
// Prints "answered STATUS" and exits 0 when drivebusd answered Ok; anything else is non-zero.
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <thread>

#include "drivebus/shm.hpp"
#include "iceoryx_posh/popo/untyped_client.hpp"
#include "iceoryx_posh/runtime/posh_runtime.hpp"

int main(int argc, char** argv) {
    if (argc != 3) {
        std::fprintf(stderr, "usage: raw_request BUS VALUE\n");
        return 2;
    }
    using namespace drivebus;
    const std::string name = "raw_request-" + std::to_string(::getpid());
    iox::runtime::PoshRuntime::initRuntime(iox::RuntimeName_t(iox::cxx::TruncateToCapacity, name.c_str()));
    iox::popo::UntypedClient client({"drivebus", iox::capro::IdString_t(iox::cxx::TruncateToCapacity, argv[1]),
                                     "requests"});
    const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(3);
    while (client.getConnectionState() != iox::ConnectionState::CONNECTED && std::chrono::steady_clock::now() < until) {
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    auto loaned = client.loan(sizeof(shm::Request), alignof(shm::Request));
    if (loaned.has_error()) {
        std::printf("no request chunk: error %d\n", static_cast<int>(loaned.get_error()));
        return 3;
    }
    shm::Request r;
    r.size = sizeof r;
    r.kind = shm::RequestKind::Write;
    r.correlation = 1;
    r.client = 77;
    shm::assign(r.drive, "pump");
    r.start = 0xFA51;
    r.count = 1;
    r.values[0] = static_cast<std::uint16_t>(std::atoi(argv[2]));
    std::memcpy(loaned.value(), &r, sizeof r);
    if (client.send(loaned.value()).has_error()) {
        std::printf("send refused\n");
        return 4;
    }
    const auto answer_by = std::chrono::steady_clock::now() + std::chrono::seconds(3);
    while (std::chrono::steady_clock::now() < answer_by) {
        auto taken = client.take();
        if (!taken.has_error()) {
            shm::Response response{};
            std::memcpy(&response, taken.value(), sizeof response);
            client.releaseResponse(taken.value());
            std::printf("answered %s (%s)\n", std::string(shm::to_string(response.status)).c_str(),
                        std::string(shm::to_string(response.reason)).c_str());
            return response.status == shm::Status::Ok ? 0 : 5;
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
    std::printf("no answer\n");
    return 6;
}
