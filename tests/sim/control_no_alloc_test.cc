// A control step (ReactiveController::Step with RMPflow), the scenario's Advance/FillScene and the episode loop
// allocate nothing — counted with the global operator new that no_alloc_test.cc replaces for this binary. Also prints
// the cost of a control step for the Panda with four crossing cubes.
#include <gtest/gtest.h>

#include <cstdio>
#include <vector>

#include "../support/alloc_counter.h"
#include "rmpmarl/sim/episode.h"
#include "rmpmarl/sim/controlled_world.h"

namespace rmpmarl::sim {
namespace {

using rmpmarl::testing::AllocationCount;

std::vector<double>* volatile g_escape = nullptr;  // keeps the compiler from eliding the allocation below

TEST(ControlNoAllocTest, TheCounterSeesAnAllocation) {
  const long before = AllocationCount();
  g_escape = new std::vector<double>(100);
  const long after = AllocationCount();
  delete g_escape;
  EXPECT_EQ(after - before, 2);  // the vector object and its buffer
}

TEST(ControlNoAllocTest, ControlStepScenarioAndPhysicsDoNotAllocate) {
  const kinematics::Robot robot = kinematics::LoadShippedRobot("panda");
  for (const std::string name : {"crossing", "line-crossing", "cluttered"}) {
    const std::unique_ptr<Scenario> scenario = MakeScenario(name, robot);
    auto model = std::make_shared<const WorldModel>(robot, scenario->scene_spec());
    World world(model);
    control::ReactiveController controller(model->servos(),
                                  std::make_unique<control::RmpflowAccelerationPolicy>(robot, scenario->num_obstacles()));
    scenario->Reset(2, world);
    sim::ResetController(controller, world);
    rmp::Scene scene;
    scenario->FillScene(&scene);  // sizes the obstacle list once
    const ContactReport* contacts = &world.QueryContacts();
    const long before = AllocationCount();
    long collisions = 0;
    for (int step = 0; step < 2500; ++step) {  // 5 s
      if (step % controller.physics_steps_per_control() == 0) {
        scenario->FillScene(&scene);
        sim::StepController(controller, world, scene);
      }
      ASSERT_TRUE(world.Step().ok);
      contacts = &world.QueryContacts();
      collisions += contacts->num_collisions;
      scenario->Advance(0.002, *contacts, world);
    }
    EXPECT_EQ(AllocationCount() - before, 0) << name;
    EXPECT_GT(scenario->time(), 4.9);
    const control::ControllerStats& s = controller.stats();
    EXPECT_EQ(s.steps, 500);
    EXPECT_EQ(s.nonfinite_outputs, 0);
    std::printf("[ cost     ] panda %-13s %d obstacles, RMPflow, %d substeps: control step mean %.1f us, max %.1f us "
                "(policy + integration)\n", name.c_str(), scenario->num_obstacles(), controller.substeps(),
                s.mean_compute_us(), s.max_compute_us);
  }
}

TEST(ControlNoAllocTest, EpisodeLoopDoesNotAllocate) {
  // with the PD servos alone and with their inverse-dynamics feed-forward
  for (const bool feedforward : {false, true}) {
    SCOPED_TRACE(feedforward ? "feed-forward" : "PD alone");
    const kinematics::Robot robot = kinematics::LoadShippedRobot("ur5e");
    LineCrossingScenario scenario(robot, {.speed = 1.8});
    WorldOptions options;
    options.servo.inverse_dynamics_feedforward = feedforward;
    auto model = std::make_shared<const WorldModel>(robot, scenario.scene_spec(), options);
    World world(model);
    control::ReactiveController controller(model->servos(), std::make_unique<control::RmpflowAccelerationPolicy>(robot, scenario.num_obstacles()));
    long at_first_frame = -1, at_last_frame = -1;
    int frames = 0;
    const EpisodeMetrics r = RunEpisode({.duration = 4.0, .seed = 1, .video_fps = 10.0}, world, controller, scenario,
                                       [&](const FrameInfo& f) {
                                         const long now = AllocationCount();
                                         if (f.index == 0) at_first_frame = now;
                                         at_last_frame = now;
                                         ++frames;
                                       });
    EXPECT_EQ(frames, 41);
    EXPECT_EQ(r.length, 400);
    // between the first frame (t = 0, after the set-up) and the last, the loop ran 4 s without allocating
    EXPECT_EQ(at_last_frame - at_first_frame, 0);
  }
}

}  // namespace
}  // namespace rmpmarl::sim
