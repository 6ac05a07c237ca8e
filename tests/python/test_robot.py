"""rmpmarl.Robot: shipped and URDF robots, forward kinematics and Jacobians against finite differences."""
import os

import numpy as np
import pytest

import rmpmarl


def test_every_shipped_robot_loads_with_its_joint_layout():
    names = rmpmarl.shipped_robots()
    assert {"panda", "ur5e", "gen3"} <= set(names)
    for name in names:
        robot = rmpmarl.Robot(name)
        assert robot.name == name
        assert len(robot.joint_names) == robot.nq > 0
        assert robot.lower_limits.shape == (robot.nq,)
        assert np.all(robot.lower_limits < robot.upper_limits)
        assert robot.num_capsules > 0


def test_end_effector_jacobian_matches_finite_differences():
    robot = rmpmarl.Robot("panda")
    rng = np.random.default_rng(0)
    for _ in range(5):
        q = rng.uniform(robot.lower_limits, robot.upper_limits)
        J = robot.end_effector_jacobian(q)
        h = 1e-6
        fd = np.stack([(robot.end_effector_position(q + h * e) - robot.end_effector_position(q - h * e)) / (2 * h)
                       for e in np.eye(robot.nq)], axis=1)
        np.testing.assert_allclose(J, fd, atol=1e-8)


def test_forward_kinematics_is_consistent_with_the_end_effector_and_capsules():
    robot = rmpmarl.Robot("ur5e")
    q = np.linspace(-1.0, 1.0, robot.nq)
    X = robot.forward_kinematics(q)
    assert X.shape == (len(robot.link_names), 4, 4)
    np.testing.assert_allclose(X[:, 3, :], np.tile([0, 0, 0, 1.0], (X.shape[0], 1)))
    for R in X[:, :3, :3]:
        np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-12)
    np.testing.assert_allclose(robot.end_effector_pose(q)[:3, 3], robot.end_effector_position(q), atol=1e-15)
    # the end-effector point's Jacobian through point_jacobian: p_LP is the end effector's offset in its link
    k = robot.link_index(robot.end_effector_link)
    X_WL = X[k]
    p_LE = X_WL[:3, :3].T @ (robot.end_effector_position(q) - X_WL[:3, 3])
    np.testing.assert_allclose(robot.point_jacobian(q, robot.end_effector_link, p_LE), robot.end_effector_jacobian(q),
                               atol=1e-12)
    caps = robot.capsules(q)
    assert caps.shape == (robot.num_capsules, 7) and np.all(caps[:, 6] > 0)


def test_self_collision_capsules_are_the_yamls_second_cover_or_the_capsules(tmp_path):
    panda = rmpmarl.Robot("panda")
    q = np.linspace(-0.5, 0.5, panda.nq)
    np.testing.assert_array_equal(panda.self_collision_capsules(q), panda.capsules(q))
    # the shipped YAML with a second, fatter cover of the same capsules
    directory = os.path.join(rmpmarl.models_directory(), "robots", "panda")
    text = open(os.path.join(directory, "collision.yaml")).read()
    lines = [line for line in text.splitlines() if line.lstrip().startswith("- {link:")]
    fatter = []
    for line in lines:
        head, radius = line.rsplit("radius:", 1)
        fatter.append(f"{head}radius: {float(radius.strip().rstrip('}')) + 0.01}}}")
    yaml = tmp_path / "panda.collision.yaml"
    yaml.write_text(text + "\nself_collision_capsules:\n" + "\n".join(fatter) + "\n")
    robot = rmpmarl.Robot.from_urdf(os.path.join(directory, "panda.urdf"), collision=str(yaml))
    caps, self_caps = robot.capsules(q), robot.self_collision_capsules(q)
    assert self_caps.shape == caps.shape == (len(lines), 7)
    np.testing.assert_allclose(self_caps[:, :6], caps[:, :6], atol=1e-15)
    np.testing.assert_allclose(self_caps[:, 6], caps[:, 6] + 0.01, atol=1e-12)


def test_a_urdf_loads_with_fitted_capsules_and_the_same_kinematics():
    panda = rmpmarl.Robot("panda")
    urdf = os.path.join(rmpmarl.models_directory(), "robots", "panda", "panda.urdf")
    user = rmpmarl.Robot.from_urdf(urdf)
    q = np.full(panda.nq, 0.3)
    np.testing.assert_allclose(user.end_effector_jacobian(q), panda.end_effector_jacobian(q), atol=1e-12)
    assert rmpmarl.Robot(urdf).nq == 7


@pytest.mark.parametrize("q, message", [
    (np.zeros(6), "q: expected shape float64[7], got float64[6]"),
    (np.zeros(7, np.float32), "q: expected a float64[7] array, got float32[7]"),
    (np.zeros(14)[::2], "q: expected a C-contiguous array"),
    (np.array([0, 0, 0, np.nan, 0, 0, 0]), "q: expected finite values"),
    ("0000000", "q: expected a float64[7] array, got str"),
    (["a"] * 7, "q: expected float64[7] (numbers), got a sequence that is not numeric"),
])
def test_bad_joint_vectors_raise_value_error_naming_the_argument(q, message):
    robot = rmpmarl.Robot("panda")
    with pytest.raises(ValueError) as e:
        robot.end_effector_jacobian(q)
    assert message in str(e.value)


def test_unknown_robots_and_missing_files_raise():
    with pytest.raises(ValueError, match="no-such-arm"):
        rmpmarl.Robot("no-such-arm")
    with pytest.raises(FileNotFoundError, match="urdf: expected a URDF file, got 'missing.urdf'"):
        rmpmarl.Robot.from_urdf("missing.urdf")
    with pytest.raises(ValueError, match="link: expected an index in"):
        rmpmarl.Robot("panda").point_jacobian(np.zeros(7), 99, [0, 0, 0])
    with pytest.raises(ValueError, match="no link named .no_link. \\(links: panda_link0"):
        rmpmarl.Robot("panda").link_index("no_link")
    assert rmpmarl.Robot("panda").end_effector_jacobian([0.0] * 7).shape == (3, 7)  # a list of numbers is fine
