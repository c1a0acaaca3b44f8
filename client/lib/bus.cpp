#include <grp.h>
#include <pwd.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <random>
#include <utility>

#include "bus_impl.hpp"
#include "iceoryx_hoofs/log/logmanager.hpp"
#include "iceoryx_posh/runtime/posh_runtime.hpp"
#include "iceoryx_posh/runtime/service_discovery.hpp"

namespace drivebus {
namespace {

constexpr char kRouDiSocket[] = "/tmp/roudi";
constexpr char kManagementShm[] = "/dev/shm/iceoryx_mgmt";

iox::capro::IdString_t id(std::string_view text) {
    return {iox::cxx::TruncateToCapacity, std::string(text).c_str()};
}

// 0 when RouDi answers on its socket, else the errno of the attempt.
int roudi_answers() {
    const int fd = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    if (fd < 0) {
        return errno;
    }
    sockaddr_un addr{};
    addr.sun_family = AF_UNIX;
    std::strncpy(addr.sun_path, kRouDiSocket, sizeof(addr.sun_path) - 1);
    const int rc = ::connect(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) == 0 ? 0 : errno;
    ::close(fd);
    return rc;
}

std::string group_of(const char* path) {
    struct stat st {};
    if (::stat(path, &st) == 0) {
        if (const auto* g = ::getgrgid(st.st_gid)) {
            return g->gr_name;
        }
    }
    return "drivebus";
}

bool user_in_group(const std::string& group) {
    const auto* g = ::getgrnam(group.c_str());
    if (g == nullptr) {
        return false;
    }
    if (::getegid() == g->gr_gid) {
        return true;
    }
    // RouDi decides by the user's groups as the group database lists them, not by the groups
    // this process happens to carry: ask the same way.
    const auto* pw = ::getpwuid(::geteuid());
    if (pw == nullptr) {
        return false;
    }
    int n = 64;
    std::vector<gid_t> gids(static_cast<std::size_t>(n));
    if (::getgrouplist(pw->pw_name, pw->pw_gid, gids.data(), &n) < 0) {
        gids.resize(static_cast<std::size_t>(n));
        ::getgrouplist(pw->pw_name, pw->pw_gid, gids.data(), &n);
    }
    gids.resize(static_cast<std::size_t>(std::max(n, 0)));
    return std::ranges::find(gids, g->gr_gid) != gids.end();
}

std::string runtime_name(const std::string& application) {
    std::string name;
    for (const char c : application) {
        name += (std::isalnum(static_cast<unsigned char>(c)) != 0 || c == '-' || c == '_') ? c : '_';
    }
    name = name.substr(0, 60) + "-" + std::to_string(::getpid());
    return name;
}

std::uint64_t random_id() {
    std::random_device rd;
    const std::uint64_t r = (static_cast<std::uint64_t>(rd()) << 32) ^ rd();
    return (r << 16) ^ static_cast<std::uint64_t>(::getpid()) ^ 1U;
}

}  // namespace

std::string exception_text(std::uint8_t code) {
    switch (code) {
    case 1: return "illegal function";
    case 2: return "illegal data address";
    case 3: return "illegal data value";
    case 4: return "slave device failure";
    case 5: return "acknowledge";
    case 6: return "slave device busy";
    default: return "exception";
    }
}

namespace {

std::vector<std::string> discover_buses(std::chrono::milliseconds wait) {
    iox::runtime::ServiceDiscovery discovery;
    std::vector<std::string> buses;
    const auto deadline = Clock::now() + wait;
    do {
        buses.clear();
        discovery.findService(
            iox::cxx::optional<iox::capro::IdString_t>(id(shm::kService)), iox::cxx::nullopt,
            iox::cxx::optional<iox::capro::IdString_t>(id(shm::kStatusEvent)),
            [&](const iox::capro::ServiceDescription& s) { buses.emplace_back(s.getInstanceIDString().c_str()); },
            iox::popo::MessagingPattern::PUB_SUB);
        if (!buses.empty()) {
            break;
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
    } while (Clock::now() < deadline);
    std::ranges::sort(buses);
    buses.erase(std::unique(buses.begin(), buses.end()), buses.end());
    return buses;
}

}  // namespace

Error make_error(ErrorKind kind, std::string message) {
    Error e;
    e.kind = kind;
    e.message = std::move(message);
    return e;
}

std::string_view to_string(ErrorKind kind) noexcept {
    switch (kind) {
    case ErrorKind::Exception: return "exception";
    case ErrorKind::Timeout: return "timeout";
    case ErrorKind::LateReply: return "late reply";
    case ErrorKind::BadFrame: return "bad frame";
    case ErrorKind::Rejected: return "rejected";
    case ErrorKind::QueueFull: return "queue full";
    case ErrorKind::BusDown: return "bus down";
    case ErrorKind::NotPermitted: return "not permitted";
    case ErrorKind::NotRunning: return "not running";
    case ErrorKind::NoSuchBus: return "no such bus";
    case ErrorKind::DaemonGone: return "daemon gone";
    case ErrorKind::NoReply: return "no reply";
    case ErrorKind::Withdrawn: return "withdrawn";
    case ErrorKind::OutcomeUnknown: return "outcome unknown";
    case ErrorKind::InvalidArgument: return "invalid argument";
    case ErrorKind::Unsupported: return "unsupported";
    }
    return "error";
}

std::expected<void, Error> ensure_runtime(const std::string& application) {
    static std::once_flag once;
    static bool started = false;
    if (const int error = roudi_answers(); error != 0) {
        if (error == EACCES) {
            const auto group = group_of(kRouDiSocket);
            struct stat st {};
            ::stat(kRouDiSocket, &st);
            char mode[8];
            std::snprintf(mode, sizeof mode, "%04o", st.st_mode & 07777U);
            return std::unexpected(make_error(ErrorKind::NotPermitted, "this user may not reach drivebusd's RouDi "
                                                                       "(/tmp/roudi, group " +
                                                                           group + ", mode " + mode + "): join group " +
                                                                           group + " and log in again"));
        }
        return std::unexpected(make_error(ErrorKind::NotRunning, std::string("drivebusd is not running (/tmp/roudi: ") +
                                                                     std::strerror(error) +
                                                                     "); start it: systemctl start drivebusd"));
    }
    if (::access(kManagementShm, R_OK | W_OK) != 0) {
        const auto group = group_of(kManagementShm);
        return std::unexpected(make_error(ErrorKind::NotPermitted,
                                          "this user may not use drivebus's shared memory: join group " + group +
                                              " (usermod -aG " + group + " $USER) and log in again"));
    }
    // RouDi answers each process through a socket the process creates with its effective
    // group and mode 0660: unless RouDi runs as root or as this user, that group must be RouDi's.
    struct stat roudi {};
    if (::stat(kRouDiSocket, &roudi) == 0 && roudi.st_uid != 0 && roudi.st_uid != ::geteuid() &&
        roudi.st_gid != ::getegid()) {
        const auto group = group_of(kRouDiSocket);
        return std::unexpected(make_error(ErrorKind::NotPermitted,
                                          "this process's effective group must be " + group +
                                              " for drivebusd to answer it: run it with sg " + group +
                                              " -c '...', or Group=" + group + " in its unit"));
    }
    std::call_once(once, [&] {
        iox::log::LogManager::GetLogManager().SetDefaultLogLevel(iox::log::LogLevel::kError,
                                                                 iox::log::LogLevelOutput::kHideLogLevel);
        const auto name = runtime_name(application);
        iox::runtime::PoshRuntime::initRuntime(iox::RuntimeName_t(iox::cxx::TruncateToCapacity, name.c_str()));
        started = true;
    });
    if (!started) {
        return std::unexpected(make_error(ErrorKind::NotRunning, "the iceoryx runtime could not start"));
    }
    return {};
}

// ---- Bus::Impl ----

Bus::Impl::Impl(std::string bus, ConnectOptions connect_options)
    : name(std::move(bus)), options(std::move(connect_options)), client_id(random_id()) {
    client_name = options.application + "[" + std::to_string(::getpid()) + "]";
    gate->impl = this;
}

Bus::Impl::~Impl() {
    {
        const std::lock_guard lock(gate->mutex);  // after a callback under way
        gate->impl = nullptr;
    }
    if (!alive()) {
        (void)listener.release();
        (void)gate.release();
        // RouDi went with drivebusd: giving the ports back would touch shared memory nobody
        // manages any more (iceoryx aborts on it). The process keeps them until it ends, and
        // the feeds with them (the listener's contexts point into them).
        for (auto& d : drives) {
            (void)d->subscriber.release();
            (void)d.release();
        }
        (void)client.release();
        (void)status_subscriber.release();
        return;
    }
    listener.reset();
    for (auto& d : drives) {
        d->subscriber.reset();
    }
    client.reset();
    status_subscriber.reset();
}

namespace {

// A callback on the listener's thread, unless the Impl is going away.
template <typename F>
void through(CallbackGate& gate, F&& f) {
    const std::lock_guard lock(gate.mutex);
    if (gate.impl != nullptr) {
        std::forward<F>(f)(*gate.impl);
    }
}

void status_arrived(iox::popo::Subscriber<shm::BusStatus>* /*unused*/, CallbackGate* gate) {
    through(*gate, [](Bus::Impl& impl) { impl.on_status_sample(); });
}

void snapshot_arrived(iox::popo::Subscriber<shm::DriveSnapshot>* /*unused*/, DriveFeed::Context* context) {
    through(*context->gate, [&](Bus::Impl& impl) { impl.on_drive_sample(*context->feed); });
}

void response_arrived(iox::popo::UntypedClient* /*unused*/, CallbackGate* gate) {
    through(*gate, [](Bus::Impl& impl) { impl.on_response(); });
}

}  // namespace

std::expected<void, Error> Bus::Impl::open() {
    listener = std::make_unique<iox::popo::Listener>();
    iox::popo::SubscriberOptions status_options;
    status_options.historyRequest = 1;
    status_options.queueCapacity = 4;
    status_subscriber = std::make_unique<iox::popo::Subscriber<shm::BusStatus>>(
        iox::capro::ServiceDescription{id(shm::kService), id(name), id(shm::kStatusEvent)}, status_options);
    (void)listener->attachEvent(*status_subscriber, iox::popo::SubscriberEvent::DATA_RECEIVED,
                                iox::popo::createNotificationCallback(status_arrived, *gate));
    on_status_sample();  // a sample that came before the listener did
    shm::BusStatus first;
    {
        std::unique_lock lock(mutex);
        changed.wait_for(lock, options.connect_timeout, [&] { return status.has_value(); });
        if (!status) {
            return std::unexpected(make_error(ErrorKind::NoSuchBus, "drivebusd does not announce bus '" + name +
                                                                        "' (drivebusctl list shows the buses)"));
        }
        first = *status;  // the listener's thread keeps writing it
    }
    const auto group = std::string(shm::view(first.control_group));
    may_request = group.empty() || user_in_group(group);

    for (std::size_t i = 0; i < first.drive_count && i < first.drives.size(); ++i) {
        auto feed = std::make_unique<DriveFeed>();
        feed->name = std::string(shm::view(first.drives[i].name));
        feed->address = first.drives[i].address;
        const auto type = std::string(shm::view(first.drives[i].profile));
        auto profile = options.profile_dir ? load_profile(*options.profile_dir / (type + ".toml"))
                                           : load_profile_by_type(type);
        if (profile) {
            feed->profile = std::make_shared<const Profile>(std::move(*profile));
        }
        feed->context = {gate.get(), feed.get()};
        iox::popo::SubscriberOptions o;
        o.historyRequest = 1;
        o.queueCapacity = 2;
        feed->subscriber = std::make_unique<iox::popo::Subscriber<shm::DriveSnapshot>>(
            iox::capro::ServiceDescription{id(shm::kService), id(name),
                                           id(std::string(shm::kDriveEventPrefix) + feed->name)},
            o);
        auto* raw = feed.get();
        {
            std::lock_guard lock(mutex);
            drives.push_back(std::move(feed));
        }
        (void)listener->attachEvent(*raw->subscriber, iox::popo::SubscriberEvent::DATA_RECEIVED,
                                    iox::popo::createNotificationCallback(snapshot_arrived, raw->context));
        on_drive_sample(*raw);
    }

    if (may_request) {
        iox::popo::ClientOptions o;
        o.responseQueueCapacity = iox::popo::ClientChunkQueueData_t::MAX_CAPACITY;
        client = std::make_unique<iox::popo::UntypedClient>(
            iox::capro::ServiceDescription{id(shm::kService), id(name), id(shm::kRequestEvent)}, o);
        (void)listener->attachEvent(*client, iox::popo::ClientEvent::RESPONSE_RECEIVED,
                                    iox::popo::createNotificationCallback(response_arrived, *gate));
        const auto deadline = Clock::now() + options.connect_timeout;
        while (client->getConnectionState() != iox::ConnectionState::CONNECTED && Clock::now() < deadline) {
            std::this_thread::sleep_for(std::chrono::milliseconds(2));
        }
        if (client->getConnectionState() != iox::ConnectionState::CONNECTED) {
            return std::unexpected(
                make_error(ErrorKind::NoSuchBus, "bus '" + name + "' takes no requests (its server did not answer)"));
        }
    }
    return {};
}

void Bus::Impl::on_status_sample() {
    for (;;) {
        auto sample = status_subscriber->take();
        if (sample.has_error()) {
            return;
        }
        if (!shm::compatible(*sample.value().get())) {
            continue;
        }
        std::vector<std::function<void(const shm::BusStatus&)>> callbacks;
        {
            std::lock_guard lock(mutex);
            status = *sample.value().get();
            status_time = Clock::now();
            for (const auto& [key, cb] : status_callbacks) {
                callbacks.push_back(cb);
            }
        }
        changed.notify_all();
        for (const auto& cb : callbacks) {
            cb(*sample.value().get());
        }
    }
}

void Bus::Impl::on_drive_sample(DriveFeed& feed) {
    for (;;) {
        auto sample = feed.subscriber->take();
        if (sample.has_error()) {
            return;
        }
        const auto& s = *sample.value().get();
        if (!shm::compatible(s)) {
            continue;
        }
        std::vector<std::function<void(const shm::DriveSnapshot&)>> callbacks;
        {
            std::lock_guard lock(mutex);
            feed.last = s;
            for (const auto& [key, cb] : feed.callbacks) {
                callbacks.push_back(cb);
            }
        }
        changed.notify_all();
        for (const auto& cb : callbacks) {
            cb(s);
        }
    }
}

void Bus::Impl::on_response() {
    std::vector<shm::Response> got;
    {
        std::lock_guard lock(client_mutex);
        for (;;) {
            auto taken = client->take();
            if (taken.has_error()) {
                break;
            }
            shm::Response r{};
            std::memcpy(&r, taken.value(), sizeof r);
            client->releaseResponse(taken.value());
            got.push_back(r);
        }
    }
    {
        std::lock_guard lock(mutex);
        for (const auto& r : got) {
            if (auto it = waiting.find(r.correlation); it != waiting.end()) {
                it->second = r;
            }
        }
    }
    changed.notify_all();
}

bool Bus::Impl::alive() const {
    std::lock_guard lock(mutex);
    return status.has_value() && Clock::now() - status_time < options.daemon_silence;
}

DriveFeed* Bus::Impl::feed(std::string_view which) {
    std::lock_guard lock(mutex);
    for (auto& d : drives) {
        if (d->name == which) {
            return d.get();
        }
    }
    return nullptr;
}

bool Bus::Impl::send(const shm::Request& request) {
    std::lock_guard lock(client_mutex);
    auto loaned = client->loan(sizeof(shm::Request), alignof(shm::Request));
    if (loaned.has_error()) {
        return false;
    }
    std::memcpy(loaned.value(), &request, sizeof request);
    return !client->send(loaned.value()).has_error();
}

std::expected<shm::Response, Error> Bus::Impl::call(shm::Request request) {
    if (!client) {
        std::string group;
        {
            std::lock_guard lock(mutex);  // the listener's thread writes the status
            group = std::string(shm::view(status->control_group));
        }
        return std::unexpected(make_error(ErrorKind::NotPermitted, "requests on bus '" + name +
                                                                       "' need membership of group " + group +
                                                                       " (usermod -aG " + group +
                                                                       " $USER); watching needs none"));
    }
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
    {
        std::lock_guard lock(mutex);
        if (request.lease_token == shm::LeaseToken{}) {
            const auto it = lease_tokens.find(shm::view(request.drive));
            request.lease_token = it != lease_tokens.end() ? it->second : latest_token;
        }
        request.correlation = next_correlation++;
        waiting.emplace(request.correlation, std::nullopt);
    }
    const bool sent = send(request);
    std::unique_lock lock(mutex);
    if (!sent) {
        waiting.erase(request.correlation);
        return std::unexpected(make_error(ErrorKind::DaemonGone, "drivebusd is not taking requests on bus '" + name +
                                                                     "' (has it stopped?)"));
    }
    bool answered = changed.wait_for(lock, options.request_timeout,
                                     [&] { return waiting.at(request.correlation).has_value(); });
    if (!answered) {
        // Given up: withdrawn if it has not reached the wire, and told which happened. The
        // answer is the request's own result if it finished meanwhile.
        lock.unlock();
        shm::Request withdraw = request;
        withdraw.kind = shm::RequestKind::Withdraw;
        const bool asked = send(withdraw);
        lock.lock();
        if (asked) {
            answered = changed.wait_for(lock, std::clamp(options.request_timeout, Milliseconds(200), Milliseconds(1000)),
                                        [&] { return waiting.at(request.correlation).has_value(); });
        }
    }
    auto response = waiting.at(request.correlation);
    waiting.erase(request.correlation);
    if (response && response->status == shm::Status::Rejected && response->reason == shm::RejectReason::NotPending) {
        response.reset();  // drivebusd holds no such request: its answer was lost, or it never came
        answered = false;
    }
    if (response && response->lease_ms > 0 && response->lease_token != shm::LeaseToken{}) {
        // This request took a lease: its token from now on.
        lease_tokens[std::string(shm::view(request.drive))] = response->lease_token;
        latest_token = response->lease_token;
    }
    if (!answered || !response) {
        const bool gone = !(status.has_value() && Clock::now() - status_time < options.daemon_silence);
        return std::unexpected(gone ? make_error(ErrorKind::DaemonGone,
                                                 "drivebusd has gone silent (no bus status for " +
                                                     std::to_string(options.daemon_silence.count()) + " ms)")
                                    : make_error(ErrorKind::NoReply, "drivebusd did not answer within " +
                                                                         std::to_string(options.request_timeout.count()) +
                                                                         " ms, nor its withdrawal: the outcome is "
                                                                         "unknown (read the register back)"));
    }
    return *response;
}

// ---- Bus ----

Bus::Bus(std::shared_ptr<Impl> impl) : impl_(std::move(impl)) {}
Bus::~Bus() = default;
Bus::Bus(Bus&&) noexcept = default;
Bus& Bus::operator=(Bus&&) noexcept = default;

std::expected<Bus, Error> Bus::connect(std::string_view bus, ConnectOptions options) {
    if (auto ok = ensure_runtime(options.application); !ok) {
        return std::unexpected(ok.error());
    }
    std::string name(bus);
    if (name.empty()) {
        const auto buses = discover_buses(options.connect_timeout);
        if (buses.empty()) {
            return std::unexpected(make_error(ErrorKind::NoSuchBus, "drivebusd announces no bus"));
        }
        if (buses.size() > 1) {
            std::string list;
            for (const auto& b : buses) {
                list += (list.empty() ? "" : ", ") + b;
            }
            return std::unexpected(
                make_error(ErrorKind::InvalidArgument, "drivebusd runs several buses (" + list + "): name one"));
        }
        name = buses.front();
    }
    auto impl = std::make_shared<Impl>(name, std::move(options));
    if (auto ok = impl->open(); !ok) {
        return std::unexpected(ok.error());
    }
    return Bus(std::move(impl));
}

std::expected<std::vector<std::string>, Error> Bus::list(ConnectOptions options) {
    if (auto ok = ensure_runtime(options.application); !ok) {
        return std::unexpected(ok.error());
    }
    return discover_buses(options.connect_timeout);
}

const std::string& Bus::name() const noexcept {
    return impl_->name;
}

std::expected<shm::BusStatus, Error> Bus::status(Milliseconds wait) const {
    std::unique_lock lock(impl_->mutex);
    impl_->changed.wait_for(lock, wait, [&] { return impl_->status.has_value(); });
    if (!impl_->status) {
        return std::unexpected(make_error(ErrorKind::DaemonGone, "no status from bus '" + impl_->name + "'"));
    }
    return *impl_->status;
}

bool Bus::daemon_alive() const {
    return impl_->alive();
}

bool Bus::can_request() const {
    return impl_->may_request;
}

std::uint64_t Bus::client_id() const noexcept {
    return impl_->client_id;
}

Subscription Bus::on_status(std::function<void(const shm::BusStatus&)> callback) const {
    std::uint64_t key = 0;
    {
        std::lock_guard lock(impl_->mutex);
        key = impl_->next_callback++;
        impl_->status_callbacks.emplace(key, std::move(callback));
    }
    return Subscription([impl = impl_, key] {
        std::lock_guard lock(impl->mutex);
        impl->status_callbacks.erase(key);
    });
}

std::expected<shm::Response, Error> Bus::request(shm::Request request) const {
    return impl_->call(request);
}

std::expected<Drive, Error> Bus::drive(std::string_view which) const {
    std::lock_guard lock(impl_->mutex);
    for (const auto& d : impl_->drives) {
        if (d->name == which || std::to_string(d->address) == which) {
            return Drive(impl_, d->name, d->address, d->profile);
        }
    }
    std::string names;
    for (const auto& d : impl_->drives) {
        names += (names.empty() ? "" : ", ") + d->name + " (" + std::to_string(d->address) + ")";
    }
    return std::unexpected(make_error(ErrorKind::InvalidArgument, "bus '" + impl_->name + "' has no drive '" +
                                                                      std::string(which) + "'; it has " + names));
}

std::expected<void, Error> Bus::broadcast(std::uint16_t address, std::span<const std::uint16_t> values) const {
    if (values.empty() || values.size() > shm::kMaxWriteWords) {
        return std::unexpected(make_error(ErrorKind::InvalidArgument, "a broadcast carries 1-123 words"));
    }
    shm::Request r;
    r.kind = shm::RequestKind::Broadcast;
    r.start = address;
    r.count = static_cast<std::uint16_t>(values.size());
    std::ranges::copy(values, r.values.begin());
    auto response = impl_->call(r);
    if (!response) {
        return std::unexpected(response.error());
    }
    return check_response("bus '" + impl_->name + "' (broadcast)", *response);
}

std::expected<void, Error> check_response(const std::string& what, const shm::Response& r, const Profile* profile) {
    Error e;
    e.exception = r.exception;
    e.reason = r.reason;
    e.lease_holder = std::string(shm::view(r.lease_holder));
    e.lease_holder_pid = r.lease_holder_pid;
    switch (r.status) {
    case shm::Status::Ok: return {};
    case shm::Status::Exception:
        e.kind = ErrorKind::Exception;
        e.message = what + " answered exception " + std::to_string(r.exception) + " (" + exception_text(r.exception) +
                    ")";
        break;
    case shm::Status::Timeout:
        e.kind = ErrorKind::Timeout;
        e.message = what + " did not answer (" + std::to_string(r.attempts) +
                    " attempts): check its address, wiring and line settings";
        break;
    case shm::Status::Late:
        e.kind = ErrorKind::LateReply;
        e.message = what + " answers too late: after about " + std::to_string((r.late_us + 500) / 1000) +
                    " ms, past the response time-out (" + std::to_string(r.attempts) +
                    " attempts): raise the bus's response_timeout above that";
        break;
    case shm::Status::BadFrame:
        e.kind = ErrorKind::BadFrame;
        e.message = what + ": the reply was spoiled (CRC, framing, parity or echo): check wiring and termination";
        break;
    case shm::Status::Rejected:
        e.kind = ErrorKind::Rejected;
        e.message = "drivebusd rejected the request to " + what + ": " + rejection_text(r, profile);
        break;
    case shm::Status::QueueFull:
        e.kind = ErrorKind::QueueFull;
        e.message = "the bus's request queue is full; try again shortly";
        break;
    case shm::Status::BusDown:
        e.kind = ErrorKind::BusDown;
        e.message = "the bus is down: its serial device is not open (see journalctl -u drivebusd)";
        break;
    case shm::Status::Withdrawn:
        e.kind = ErrorKind::Withdrawn;
        e.message = "drivebusd did not answer in time; the request to " + what +
                    " was withdrawn before it reached the drive: nothing was sent";
        break;
    case shm::Status::Sent:
        e.kind = ErrorKind::OutcomeUnknown;
        e.message = "drivebusd did not answer in time; the request to " + what +
                    " had already been sent: its outcome is unknown (read the register back)";
        break;
    case shm::Status::NotPermitted:
        e.kind = ErrorKind::NotPermitted;
        if (e.lease_holder.empty()) {
            e.message = "this process does not hold the control lease of " + what +
                        " (it ran out, was taken over or was never taken): write the command or reference to "
                        "take it";
        } else {
            e.message = "another client (" + e.lease_holder + ", pid " + std::to_string(e.lease_holder_pid) +
                        ") holds the control lease of " + what +
                        "; take it over explicitly (drivebusctl write --take-over, WriteOptions::take_over)";
        }
        break;
    }
    return std::unexpected(e);
}

}  // namespace drivebus
