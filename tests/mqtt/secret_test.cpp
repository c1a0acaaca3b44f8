// SPDX-License-Identifier: Apache-2.0
// Which secret files the bridge refuses (mqtt::secret_problem): owner, mode and the members of
// the file's group, as the caller read them.
#include <gtest/gtest.h>

#include "mqtt/secret.hpp"

namespace drivebus::mqtt {
namespace {

const Account kBridge{.uid = 998, .name = "drivebus-mqtt"};
const Account kRoot{.uid = 0, .name = "root"};

SecretFile file(unsigned mode, std::string group, std::vector<std::string> members, Account owner = kRoot) {
    return SecretFile{.key = "broker.password_file",
                      .path = "/etc/drivebus/mqtt.password",
                      .owner = std::move(owner),
                      .mode = mode,
                      .group = std::move(group),
                      .group_members = std::move(members)};
}

TEST(MqttSecret, TheInstalledLayoutPasses) {
    // root:drivebus-mqtt 0640, the group holding the bridge's user alone (drivebus.conf).
    EXPECT_EQ(secret_problem(file(0640, "drivebus-mqtt", {"drivebus-mqtt"}), kBridge), std::nullopt);
    // The bridge's own file, or root's, closed to the group.
    EXPECT_EQ(secret_problem(file(0600, "drivebus", {"drivebus", "alice"}, kBridge), kBridge), std::nullopt);
    EXPECT_EQ(secret_problem(file(0400, "root", {}), kBridge), std::nullopt);
}

TEST(MqttSecret, AFileOthersMayReadIsRefusedSayingHowToCloseIt) {
    const auto problem = secret_problem(file(0644, "drivebus-mqtt", {"drivebus-mqtt"}), kBridge);
    ASSERT_TRUE(problem);
    EXPECT_NE(problem->find("broker.password_file: /etc/drivebus/mqtt.password"), std::string::npos) << *problem;
    EXPECT_NE(problem->find("mode 0644"), std::string::npos) << *problem;
    EXPECT_NE(problem->find("chmod o= /etc/drivebus/mqtt.password"), std::string::npos) << *problem;
    // Write or execute for others is as bad: anyone could put their own password in.
    EXPECT_TRUE(secret_problem(file(0602, "drivebus-mqtt", {"drivebus-mqtt"}), kBridge));
    EXPECT_TRUE(secret_problem(file(0601, "drivebus-mqtt", {"drivebus-mqtt"}), kBridge));
    // Even run as root.
    EXPECT_TRUE(secret_problem(file(0604, "root", {}), kRoot));
}

TEST(MqttSecret, TheWatchersGroupIsRefusedNamingItsOtherMembers) {
    // An older installation's root:drivebus: every watcher of the drives could read the password.
    const auto problem =
        secret_problem(file(0640, "drivebus", {"drivebus-mqtt", "drivebus-gateway", "alice", "drivebus"}), kBridge);
    ASSERT_TRUE(problem);
    EXPECT_NE(problem->find("group drivebus"), std::string::npos) << *problem;
    EXPECT_NE(problem->find("alice, drivebus, drivebus-gateway"), std::string::npos) << *problem;
    EXPECT_NE(problem->find("chgrp drivebus-mqtt /etc/drivebus/mqtt.password"), std::string::npos) << *problem;
    // Group write alone is refused too, and a group of one other account.
    EXPECT_TRUE(secret_problem(file(0620, "drivebus", {"alice", "bob"}), kBridge));
    EXPECT_TRUE(secret_problem(file(0640, "alice", {"alice"}), kBridge));
}

TEST(MqttSecret, RootCheckingTheServicesFileTakesAGroupOfOneAccountAsTheServices) {
    // drivebus-mqtt --check-config by an administrator: root:drivebus-mqtt 0640 passes, a group
    // of two does not.
    EXPECT_EQ(secret_problem(file(0640, "drivebus-mqtt", {"drivebus-mqtt"}), kRoot), std::nullopt);
    EXPECT_EQ(secret_problem(file(0640, "root", {"root"}), kRoot), std::nullopt);
    EXPECT_TRUE(secret_problem(file(0640, "drivebus", {"drivebus-mqtt", "alice"}), kRoot));
}

TEST(MqttSecret, AnOwnerOtherThanRootOrTheBridgeIsRefused) {
    const auto problem = secret_problem(file(0600, "alice", {"alice"}, Account{.uid = 1000, .name = "alice"}), kBridge);
    ASSERT_TRUE(problem);
    EXPECT_NE(problem->find("belongs to alice"), std::string::npos) << *problem;
}

TEST(MqttSecret, AMemberListedTwiceIsNamedOnce) {
    const auto problem = secret_problem(file(0640, "staff", {"bob", "bob", "drivebus-mqtt", "carol"}), kBridge);
    ASSERT_TRUE(problem);
    EXPECT_NE(problem->find(": bob, carol;"), std::string::npos) << *problem;
}

}  // namespace
}  // namespace drivebus::mqtt
