// The agents' sensing of warning contacts: each joint's nearest warning among the contacts whose sides it does not
// move together, against a brute-force reference over every joint and contact, on every shipped arm and the tree robot.
#include "rmpmarl/control/joint_agents.h"

#include <gtest/gtest.h>

#include <random>
#include <vector>

#include "../kinematics/test_robots.h"

namespace rmpmarl::control {
namespace {

// the reference: for joint i, the contact nearest among those where i moves exactly one side, seen from that side
struct Expected {
  bool present = false, flipped = false;  // flipped: a link-link contact seen from its other link's side
  double distance = std::numeric_limits<double>::infinity();
  int link = -1, partner_index = -1;
  PartnerKind partner = PartnerKind::kObstacle;
  Eigen::Vector3d n_W = Eigen::Vector3d::Zero();
};

Expected Reference(const kinematics::Model& m, int i, const std::vector<WarningContact>& contacts) {
  Expected e;
  for (const WarningContact& c : contacts) {
    const bool robot_side = m.DofMovesLink(i, c.link);
    const bool other_side = c.other_kind == PartnerKind::kLink && m.DofMovesLink(i, c.other_index);
    if (robot_side == other_side) continue;
    if (!(c.distance < e.distance)) continue;
    e.present = true;
    e.flipped = !robot_side;
    e.distance = c.distance;
    e.link = robot_side ? c.link : c.other_index;
    e.partner = robot_side ? c.other_kind : PartnerKind::kLink;
    e.partner_index = robot_side ? c.other_index : c.link;
    e.n_W = robot_side ? c.n_W : Eigen::Vector3d(-c.n_W);
  }
  return e;
}

TEST(JointAgentsTest, EachJointsWarningIsTheNearestContactItMovesOneSideOf) {
  for (const kinematics::Robot& robot : testing::AllTestRobots()) {
    const kinematics::Model& m = robot.model;
    AgentConfig config = DefaultAgentConfig("reach-avoid");
    config.observation.lookahead = 0.0;
    JointAgents agents(config, &robot);
    std::mt19937_64 rng(7);
    rmp::Scene scene;
    scene.obstacles.resize(3);
    std::uniform_int_distribution<int> link(0, m.num_links() - 1), kind(0, 2), obstacle(0, 2);
    std::uniform_real_distribution<double> distance(-0.02, 0.5), u(-1.0, 1.0);
    int self_seen_from_other_side = 0;
    for (int trial = 0; trial < 200; ++trial) {
      const Eigen::VectorXd q = testing::RandomConfiguration(m, rng);
      agents.SenseState(q, Eigen::VectorXd::Zero(m.nq()), Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero());
      std::vector<WarningContact> contacts(std::uniform_int_distribution<int>(0, 12)(rng));
      for (WarningContact& c : contacts) {
        c.link = link(rng);
        c.other_kind = static_cast<PartnerKind>(kind(rng));
        c.other_index = c.other_kind == PartnerKind::kLink ? link(rng) : c.other_kind == PartnerKind::kObstacle
                                                                               ? obstacle(rng)
                                                                               : -1;
        // equal distances now and then: the first contact in the list keeps the joint
        c.distance = trial % 7 == 0 ? 0.1 : distance(rng);
        c.n_W = Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized();
        c.p_W1 = Eigen::Vector3d(u(rng), u(rng), u(rng));
        c.p_W2 = c.p_W1 + c.distance * c.n_W;
      }
      agents.SenseContacts(contacts, scene);
      for (int i = 0; i < m.nq(); ++i) {
        const Expected e = Reference(m, i, contacts);
        const JointWarning& w = agents.warning(i);
        ASSERT_EQ(w.present, e.present) << robot.name << " joint " << i << " trial " << trial;
        if (!e.present) continue;
        EXPECT_EQ(w.distance, e.distance);
        EXPECT_EQ(w.link, e.link);
        EXPECT_EQ(w.partner, e.partner);
        EXPECT_EQ(w.partner_index, e.partner_index);
        EXPECT_EQ(w.n_W, e.n_W);
        self_seen_from_other_side += e.flipped ? 1 : 0;
      }
    }
    if (m.nq() > 1) {
      EXPECT_GT(self_seen_from_other_side, 0) << robot.name;
    }
  }
}

}  // namespace
}  // namespace rmpmarl::control
