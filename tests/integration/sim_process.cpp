// SPDX-License-Identifier: Apache-2.0
#include "sim_process.hpp"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/file.h>
#include <sys/prctl.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <thread>

#include "rtu/codec.hpp"
#include "serial/termios.hpp"
#include "sys/local.hpp"

namespace drivebus::test {
namespace fs = std::filesystem;
using namespace std::chrono_literals;

bool wait_until(const std::function<bool()>& condition, std::chrono::milliseconds timeout) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    while (!condition()) {
        if (std::chrono::steady_clock::now() > deadline) {
            return false;
        }
        std::this_thread::sleep_for(2ms);
    }
    return true;
}

namespace {

fs::path fresh_dir() {
    std::string pattern = (fs::temp_directory_path() / "drivebus-sim-test-XXXXXX").string();
    if (::mkdtemp(pattern.data()) == nullptr) {
        throw std::runtime_error("mkdtemp failed");
    }
    return pattern;
}

// The process's own state directory, removed when the process that made it exits (a forked
// child that exits does not remove it: it only ever execs or _exits, but the pid tells).
class OwnStateDir {
public:
    OwnStateDir() : owner_(::getpid()) {
        std::string pattern = (fs::temp_directory_path() / "drivebus-state-XXXXXX").string();
        if (::mkdtemp(pattern.data()) == nullptr) {
            throw std::runtime_error("mkdtemp failed");
        }
        path_ = pattern;
        // Writable by a drivebusd that runs as another user (the access tests).
        fs::permissions(path_, fs::perms::all | fs::perms::sticky_bit);
        // Set before any child is forked; a child's drivebusd inherits it.
        // NOLINTNEXTLINE(concurrency-mt-unsafe)
        if (::setenv("DRIVEBUS_STATE_DIR", path_.c_str(), 1) != 0) {
            throw std::runtime_error("setenv DRIVEBUS_STATE_DIR failed");
        }
    }
    ~OwnStateDir() {
        if (::getpid() == owner_) {
            std::error_code ec;
            fs::remove_all(path_, ec);
        }
    }
    OwnStateDir(const OwnStateDir&) = delete;
    OwnStateDir& operator=(const OwnStateDir&) = delete;
    OwnStateDir(OwnStateDir&&) = delete;
    OwnStateDir& operator=(OwnStateDir&&) = delete;
    [[nodiscard]] const fs::path& path() const noexcept { return path_; }

private:
    pid_t owner_;
    fs::path path_;
};

}  // namespace

const fs::path& own_state_dir() {
    static const OwnStateDir dir;
    return dir.path();
}

namespace {

int spawn(std::string program, const std::vector<std::string>& args, const fs::path& log) {
    // Every drivebusd a test starts keeps its lease record in the test's own directory, never
    // in /run/drivebus, where a killed one's record would reach the next test's bus.
    (void)own_state_dir();
    const pid_t pid = ::fork();
    if (pid < 0) {
        throw std::runtime_error("fork failed");
    }
    if (pid == 0) {
        // A test killed by its time-out takes its children with it: a daemon left running would
        // hold the machine's RouDi and fail every test after it.
        ::prctl(PR_SET_PDEATHSIG, SIGTERM);
        const int out = ::open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
        ::dup2(out, STDERR_FILENO);
        ::dup2(out, STDOUT_FILENO);
        std::vector<char*> argv;
        argv.push_back(program.data());
        std::vector<std::string> copy = args;
        for (auto& a : copy) {
            argv.push_back(a.data());
        }
        argv.push_back(nullptr);
        ::execv(program.c_str(), argv.data());
        ::_exit(127);
    }
    return pid;
}

int wait_exit(int pid, std::chrono::milliseconds timeout) {
    int status = 0;
    const bool done = wait_until([&] { return ::waitpid(pid, &status, WNOHANG) == pid; }, timeout);
    if (!done) {
        ::kill(pid, SIGKILL);
        ::waitpid(pid, &status, 0);
        return -1;
    }
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

std::string slurp(const fs::path& file) {
    std::ifstream in(file);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
}

}  // namespace

SimProcess::SimProcess(std::vector<std::string> args, std::optional<fs::path> dir)
    : dir_(dir ? *dir : fresh_dir()),
      link_(dir_ / "tty"),
      control_(dir_ / "control"),
      log_(dir_ / "sim.log"),
      owns_dir_(!dir) {
    // With --device the simulator opens that tty, and the master the other end of it.
    if (const auto device = std::ranges::find(args, "--device"); device != args.end() && device + 1 != args.end()) {
        link_ = *(device + 1);
        args.insert(args.begin(), {"--control", control_.string()});
    } else {
        args.insert(args.begin(), {"--link", link_.string(), "--control", control_.string()});
    }
    pid_ = spawn(DRIVEBUS_SIM_PATH, args, log_);
    // The simulator prints its one-line banner once the line and the control socket are up.
    const bool ready = wait_until(
        [&] {
            std::error_code ec;
            return fs::exists(link_, ec) && output().find(", drives ") != std::string::npos;
        },
        5s);
    if (!ready) {
        stop();
        throw std::runtime_error("drivebus-sim did not start: " + output());
    }
}

SimProcess::~SimProcess() {
    stop();
    if (owns_dir_) {
        std::error_code ec;
        fs::remove_all(dir_, ec);
    }
}

// SIGTERM, then the exit status (-1 if it had to be killed or was not running).
int terminate(int& pid) {
    if (pid < 0) {
        return -1;
    }
    ::kill(pid, SIGTERM);
    const int status = wait_exit(pid, 5s);
    pid = -1;
    return status;
}

int SimProcess::stop() {
    return terminate(pid_);
}

std::string SimProcess::output() const {
    return slurp(log_);
}

void SimProcess::commission_read_block(int address, const std::vector<int>& selectors) const {
    const std::string drive = std::to_string(address);
    for (std::size_t slot = 0; slot < selectors.size(); ++slot) {
        const std::string line =
            "set " + drive + " F87" + std::to_string(5 + slot) + " " + std::to_string(selectors[slot]);
        if (const auto answer = command(line); answer != "ok") {
            throw std::runtime_error("drivebus-sim: " + line + ": " + answer);
        }
    }
    if (const auto answer = command("power " + drive); answer != "ok") {
        throw std::runtime_error("drivebus-sim: power " + drive + ": " + answer);
    }
}

std::string SimProcess::command(const std::string& line) const {
    sys::UniqueFd fd(::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0));
    sockaddr_un addr{};
    addr.sun_family = AF_UNIX;
    std::strncpy(addr.sun_path, control_.c_str(), sizeof addr.sun_path - 1);
    if (::connect(fd.get(), reinterpret_cast<const sockaddr*>(&addr), sizeof addr) != 0) {
        return "error: cannot connect to the control socket";
    }
    const std::string request = line + "\n";
    if (::write(fd.get(), request.data(), request.size()) != static_cast<ssize_t>(request.size())) {
        return "error: write failed";
    }
    std::string answer;
    std::array<char, 512> buffer{};
    pollfd p{fd.get(), POLLIN, 0};
    while (answer.find('\n') == std::string::npos && ::poll(&p, 1, 5000) > 0) {
        const auto n = ::read(fd.get(), buffer.data(), buffer.size());
        if (n <= 0) {
            break;
        }
        answer.append(buffer.data(), static_cast<std::size_t>(n));
    }
    if (!answer.empty() && answer.back() == '\n') {
        answer.pop_back();
    }
    return answer;
}

Child::Child(std::vector<std::string> argv) : dir_(fresh_dir()), log_(dir_ / "child.log") {
    const std::string program = argv.front();
    argv.erase(argv.begin());
    pid_ = spawn(program, argv, log_);
}

Child::~Child() {
    stop();
    std::error_code ec;
    fs::remove_all(dir_, ec);
}

int Child::stop() {
    return terminate(pid_);
}

std::string Child::output() const {
    return slurp(log_);
}

bool roudi_answers() {
    return sys::datagram_socket_answers("/tmp/roudi").has_value();
}

bool roudi_gone() {
    if (roudi_answers()) {
        return false;
    }
    const int fd = ::open("/tmp/iox-unique-roudi.lock", O_RDONLY | O_CLOEXEC | O_NOFOLLOW);
    if (fd < 0) {
        return true;
    }
    const bool held = ::flock(fd, LOCK_EX | LOCK_NB) != 0 && errno == EWOULDBLOCK;
    ::close(fd);
    return !held;
}

std::pair<int, std::string> run_program(const std::vector<std::string>& argv, std::chrono::seconds limit) {
    const fs::path dir = fresh_dir();
    const fs::path log = dir / "out.log";
    std::vector<std::string> args(argv.begin() + 1, argv.end());
    const int pid = spawn(argv.front(), args, log);
    const int status = wait_exit(pid, limit);
    std::string out = slurp(log);
    std::error_code ec;
    fs::remove_all(dir, ec);
    return {status, out};
}

std::pair<int, std::string> run_sim(const std::vector<std::string>& args) {
    const fs::path dir = fresh_dir();
    const fs::path log = dir / "sim.log";
    const int pid = spawn(DRIVEBUS_SIM_PATH, args, log);
    const int status = wait_exit(pid, 5s);
    std::string out = slurp(log);
    std::error_code ec;
    fs::remove_all(dir, ec);
    return {status, out};
}

TestMaster::TestMaster(const fs::path& device, const rtu::LineFormat& format)
    : timing_(rtu::character_timing(format).value()), framer_(timing_, rtu::InputMarking::Plain) {
    fd_.reset(::open(device.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC));
    if (!fd_) {
        throw std::runtime_error("cannot open " + device.string() + ": " + std::strerror(errno));
    }
    if (auto ok = serial::configure_line(fd_.get(), format, serial::ErrorMarking::Off); !ok) {
        throw std::runtime_error(ok.error().message());
    }
}

void TestMaster::wait_silence() {
    if (const auto last = framer_.last_activity()) {
        const auto until = *last + timing_.t3_5;
        wait_until([&] { return sys::now() >= until; }, 1s);
    }
}

Reception TestMaster::transact(const rtu::RequestAdu& request, std::chrono::milliseconds timeout) {
    const auto adu = rtu::encode_request(request);
    if (!adu) {
        throw std::runtime_error("test request does not encode");
    }
    return transact({adu->bytes().begin(), adu->bytes().end()}, request, timeout);
}

Reception TestMaster::transact(const std::vector<std::uint8_t>& request, const rtu::RequestAdu& expect,
                               std::chrono::milliseconds timeout) {
    wait_silence();
    Reception r;
    framer_.expect_reply(expect);
    // Taken before the write: the other end may read the bytes before write() returns here.
    r.written = sys::now();
    if (::write(fd_.get(), request.data(), request.size()) != static_cast<ssize_t>(request.size())) {
        throw std::runtime_error("write to the pty failed");
    }
    const auto deadline = r.written + timeout;
    std::array<std::uint8_t, 512> buffer{};
    auto take_events = [&] {
        while (auto event = framer_.next_event()) {
            if (auto* frame = std::get_if<rtu::Frame>(&*event)) {
                if (!r.reply && rtu::decode_response(expect, frame->adu.bytes()).has_value()) {
                    r.reply = *frame;
                } else {
                    r.other_frames.push_back(*frame);
                }
            } else {
                r.discarded.push_back(std::get<rtu::DiscardedFrame>(*event));
            }
        }
    };
    auto find_decoded = [&] {
        for (std::size_t start = 0; start < r.bytes.size() && !r.decoded; ++start) {
            if (auto reply = rtu::decode_response(expect, std::span(r.bytes).subspan(start))) {
                r.decoded = std::move(*reply);
                r.decoded_at = start;
            }
        }
    };
    // Read until the reply is in the bytes and the framer has finished with them.
    while (!(r.decoded && !framer_.frame_open())) {
        const auto now = sys::now();
        if (now >= deadline) {
            break;
        }
        auto wait = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - now).count() + 1;
        if (const auto frame_deadline = framer_.deadline()) {
            const auto until_frame =
                std::chrono::duration_cast<std::chrono::milliseconds>(*frame_deadline - now).count() + 1;
            wait = std::min(wait, std::max<long>(until_frame, 0));
        }
        pollfd p{fd_.get(), POLLIN, 0};
        if (::poll(&p, 1, static_cast<int>(wait)) > 0) {
            const auto n = ::read(fd_.get(), buffer.data(), buffer.size());
            const auto t = sys::now();
            if (n > 0) {
                for (ssize_t i = 0; i < n; ++i) {
                    r.bytes.push_back(buffer[static_cast<std::size_t>(i)]);
                    r.byte_times.push_back(t);
                }
                framer_.feed({buffer.data(), static_cast<std::size_t>(n)}, t);
                find_decoded();
            }
        }
        framer_.poll(sys::now());
        take_events();
    }
    framer_.expect_requests();
    return r;
}

}  // namespace drivebus::test
