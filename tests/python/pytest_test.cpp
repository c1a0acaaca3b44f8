// SPDX-License-Identifier: Apache-2.0
// The Python module's pytest suites (tests/python/test_*.py), each against a stack of its own:
// drivebus-sim and drivebusd with its RouDi (tests/ipc/stack.hpp), the pump with a 1 s lease
// whose fallback is a ramp stop. pytest's report is this test's failure message.
#include <gtest/gtest.h>

#include <cstdlib>
#include <string>

#include "stack.hpp"

namespace drivebus::test {
namespace {

using namespace std::chrono_literals;

void run_pytest(const std::string& file) {
    StackOptions options;
    options.drive_extra = "  lease = \"1s\"\n  fallback = \"stop\"\n";
    Stack stack(options);
    ::setenv("DRIVEBUS_TEST_BUS", stack.bus().c_str(), 1);
    ::setenv("DRIVEBUS_TEST_SIM_CONTROL", stack.sim().control().c_str(), 1);
    ::setenv("PYTHONPATH", DRIVEBUS_PYTHON_PATH, 1);
    ::setenv("PYTHONDONTWRITEBYTECODE", "1", 1);
    const auto [status, out] = run_program({PYTHON3_PATH, "-m", "pytest", "-q", "-p", "no:cacheprovider", "--rootdir",
                                            DRIVEBUS_PYTEST_DIR, std::string(DRIVEBUS_PYTEST_DIR) + "/" + file},
                                           240s);
    EXPECT_EQ(status, 0) << out << "\ndrivebusd:\n" << stack.daemon_output();
    // The summary line ("7 passed in 4.1s") in the test's own output.
    const auto last = out.find_last_of('\n', out.size() > 1 ? out.size() - 2 : 0);
    std::cout << file << ": " << (last == std::string::npos ? out : out.substr(last + 1));
}

TEST(Python, TheBlockingApiAgainstDrivebusdAndTheSimulator) {
    run_pytest("test_blocking.py");
}

TEST(Python, TheAsyncioApiOnTheLoopWithNoThreadOfItsOwn) {
    run_pytest("test_asyncio.py");
}

}  // namespace
}  // namespace drivebus::test
