// SPDX-License-Identifier: Apache-2.0
// drivebusctl identify and scan: the drive's device identification (FC43/14), and which
// addresses answer on the bus.
#include <fmt/format.h>

#include <string>

#include "commands.hpp"
#include "format.hpp"
#include "json.hpp"
#include "steps.hpp"
#include "view.hpp"

namespace drivebus::ctl {

int run_identify(const Options& options, const std::string& drive_name) {
    return guarded([&] {
        const auto context = fmt::format("identify {}", drive_name);
        const auto bus = connect(options);
        const auto drive = need(bus.drive(drive_name), options, context);
        const auto identity = drive.identify();
        if (!identity) {
            fail_request(options, identity.error(), drive, "identify", 0, 0, context);
        }
        if (options.json) {
            print(Json::object()
                      .set("bus", bus.name())
                      .set("drive", drive.name())
                      .set("address", drive.address())
                      .set("vendor", identity->vendor)
                      .set("product_code", identity->product_code)
                      .set("revision", identity->revision)
                      .dump());
        } else {
            print(render_fields({{"drive", fmt::format("{} (address {})", drive.name(), drive.address())},
                                 {"vendor", identity->vendor},
                                 {"product code", identity->product_code},
                                 {"revision", identity->revision}}));
        }
        return kExitOk;
    });
}

int run_scan(const Options& options, int from, int to, const std::string& reg) {
    return guarded([&] {
        if (from < 1 || to > 247 || from > to) {
            throw Failed{report(
                options, error_of(ErrorKind::InvalidArgument,
                                  fmt::format("scan --from {} --to {}: addresses run 1-247, from <= to", from, to)))};
        }
        const auto start = parse_value(reg, nullptr);
        if (!start) {
            throw Failed{report(options, error_of(ErrorKind::InvalidArgument, start.error()), "scan --register")};
        }
        const auto bus = connect(options);
        const auto status = need(bus.status(kFirstData), options);
        const bool progress = ::isatty(STDERR_FILENO) != 0;
        auto found = Json::array();
        std::vector<Row> rows = {{"ADDRESS", "DRIVE", "ANSWER"}};
        int answered = 0;
        for (int a = from; a <= to; ++a) {
            if (progress) {
                std::fprintf(stderr, "\rscanning address %d (%d-%d)...", a, from, to);
                std::fflush(stderr);
            }
            shm::Request r;
            r.kind = shm::RequestKind::Probe;
            r.address = static_cast<std::uint8_t>(a);
            r.start = *start;
            r.count = 1;
            auto response = bus.request(r);
            if (response && (response->status == shm::Status::Timeout)) {
                continue;
            }
            if (progress) {
                std::fprintf(stderr, "\r\x1b[K");
            }
            if (!response) {
                throw Failed{report(options, response.error(), fmt::format("scan address {}", a))};
            }
            std::string answer;
            switch (response->status) {
            case shm::Status::Ok:
                answer = fmt::format("value {}", response->count > 0 ? response->values[0] : 0);
                break;
            case shm::Status::Exception:
                answer = fmt::format("exception {} ({})", response->exception, exception_name(response->exception));
                break;
            case shm::Status::BadFrame: answer = "spoiled reply (something may be there)"; break;
            default: throw Failed{report(options, response_error(*response), fmt::format("scan address {}", a))};
            }
            std::string name;
            for (std::size_t i = 0; i < status.drive_count && i < status.drives.size(); ++i) {
                if (status.drives[i].address == a) {
                    name = std::string(shm::view(status.drives[i].name));
                }
            }
            rows.push_back({std::to_string(a), name.empty() ? "-" : name, answer});
            if (response->status == shm::Status::BadFrame) {
                continue;
            }
            ++answered;
            auto item = Json::object().set("address", a).set("drive", name.empty() ? Json() : Json(name));
            if (response->status == shm::Status::Ok) {
                item.set("answer", "value").set("value", response->count > 0 ? response->values[0] : 0);
            } else {
                item.set("answer", "exception").set("exception", response->exception);
            }
            found.push(std::move(item));
        }
        if (progress) {
            std::fprintf(stderr, "\r\x1b[K");
            std::fflush(stderr);
        }
        if (options.json) {
            print(Json::object()
                      .set("bus", bus.name())
                      .set("from", from)
                      .set("to", to)
                      .set("register", *start)
                      .set("found", std::move(found))
                      .dump());
        } else {
            print((rows.size() > 1 ? render_table(rows) : std::string()) +
                  fmt::format("{} of {} addresses answered (register {})\n", answered, to - from + 1, hex(*start)));
        }
        return kExitOk;
    });
}

}  // namespace drivebus::ctl
