"""Type stubs of rmpmarl._core, the compiled half of the package (python/src/*.cc)."""
from typing import Any, Optional, Sequence, Union

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]
Float32Array = npt.NDArray[np.float32]
ArrayLike = Union[npt.NDArray[Any], Sequence[float]]

class Robot:
    """A manipulator: kinematic model (URDF), collision capsules, end effector. One Robot per thread."""
    def __init__(self, name: str) -> None:
        """a shipped robot by name, 'planar2' (the two-link pre-training arm) or a path to a .urdf"""
    @staticmethod
    def from_urdf(urdf: str, collision: Optional[str] = None) -> Robot:
        """a user's URDF; collision: its collision YAML (default: beside the URDF, else capsules fitted in memory)"""
    @property
    def name(self) -> str: ...
    @property
    def nq(self) -> int:
        """joint coordinates"""
    @property
    def joint_names(self) -> list[str]: ...
    @property
    def link_names(self) -> list[str]: ...
    @property
    def lower_limits(self) -> FloatArray:
        """[nq] joint position lower limits [rad or m] (-inf for continuous joints)"""
    @property
    def upper_limits(self) -> FloatArray: ...
    @property
    def velocity_limits(self) -> FloatArray:
        """[nq] |q̇| bounds from the URDF"""
    @property
    def end_effector_link(self) -> str: ...
    @property
    def urdf_path(self) -> str: ...
    @property
    def num_capsules(self) -> int: ...
    def link_index(self, name: str) -> int: ...
    def forward_kinematics(self, q: ArrayLike) -> FloatArray:
        """poses X_WL of every link frame, [num_links, 4, 4]"""
    def end_effector_pose(self, q: ArrayLike) -> FloatArray:
        """X_WE, [4, 4]"""
    def end_effector_position(self, q: ArrayLike) -> FloatArray:
        """p_WE, [3]"""
    def end_effector_jacobian(self, q: ArrayLike) -> FloatArray:
        """position Jacobian J_WE, [3, nq]"""
    def point_jacobian(self, q: ArrayLike, link: Union[str, int], p_LP: ArrayLike) -> FloatArray:
        """position Jacobian of point p_LP fixed on `link`, [3, nq]"""
    def capsules(self, q: ArrayLike) -> FloatArray:
        """collision capsules in the world, rows [a_x, a_y, a_z, b_x, b_y, b_z, radius]"""
    def self_collision_capsules(self, q: ArrayLike) -> FloatArray:
        """the capsules checked for self-collision in the world (the YAML's second cover, else the capsules)"""

class Controller:
    """The learned agents of a controller file or RMPflow: joint state, target, obstacles in; q̈ or joint commands
    out. One controller per thread."""
    @property
    def name(self) -> str: ...
    @property
    def nq(self) -> int: ...
    @property
    def robot(self) -> Robot: ...
    @property
    def file(self) -> str: ...
    @property
    def learned(self) -> bool: ...
    @property
    def max_obstacles(self) -> int: ...
    @property
    def control_rate(self) -> float:
        """[Hz] the rate update() is meant to be called at"""
    @property
    def substeps(self) -> int: ...
    @property
    def observations(self) -> Optional[Float32Array]:
        """learned: the agents' observations of the last decision [nq, obs_dim]"""
    @property
    def actions(self) -> Optional[Float32Array]:
        """learned: the agents' actions [nq, action_size], each row from the last decision that read it"""
    def reset(self, q: ArrayLike, qd: Optional[ArrayLike] = None) -> None: ...
    def accelerations(self, q: ArrayLike, qd: ArrayLike, *, target: Optional[ArrayLike] = None,
                      target_velocity: Optional[ArrayLike] = None, spheres: Optional[ArrayLike] = None,
                      sphere_velocities: Optional[ArrayLike] = None, boxes: Optional[ArrayLike] = None,
                      box_velocities: Optional[ArrayLike] = None, box_rotations: Optional[ArrayLike] = None,
                      cylinders: Optional[ArrayLike] = None, cylinder_velocities: Optional[ArrayLike] = None,
                      cylinder_rotations: Optional[ArrayLike] = None, joint_target: Optional[ArrayLike] = None,
                      joint_target_velocity: Optional[ArrayLike] = None,
                      joint_target_acceleration: Optional[ArrayLike] = None,
                      cloud: Optional[ArrayLike] = None, cloud_time: Optional[float] = None,
                      decide: bool = True) -> FloatArray:
        """q̈ [nq] at (q, q̇); spheres [K, 4] (x, y, z, r), boxes [K, 6] (centre, half sizes), cylinders [K, 5]
        (centre, radius, half length), velocities [K, 3], box_rotations and cylinder_rotations [K, 3, 3]; joint_target
        [nq] a joint-space goal, joint_target_velocity [nq] its velocity, joint_target_acceleration [nq] its
        acceleration; cloud [N, 3] a sensor's new frame (base frame) taken at cloud_time [s]; target None holds the end
        effector"""
    def update(self, q: ArrayLike, qd: ArrayLike, *, target: Optional[ArrayLike] = None,
               target_velocity: Optional[ArrayLike] = None, spheres: Optional[ArrayLike] = None,
               sphere_velocities: Optional[ArrayLike] = None, boxes: Optional[ArrayLike] = None,
               box_velocities: Optional[ArrayLike] = None,
               box_rotations: Optional[ArrayLike] = None, cylinders: Optional[ArrayLike] = None,
               cylinder_velocities: Optional[ArrayLike] = None, cylinder_rotations: Optional[ArrayLike] = None,
               joint_target: Optional[ArrayLike] = None, joint_target_velocity: Optional[ArrayLike] = None,
               joint_target_acceleration: Optional[ArrayLike] = None, cloud: Optional[ArrayLike] = None,
               cloud_time: Optional[float] = None) -> tuple[FloatArray, FloatArray, dict[str, Any]]:
        """one control step: (q_cmd [nq], qd_cmd [nq], info); info: finite, resynced, position_clamps,
        velocity_clamps, compute_us [µs], qdd_cmd [nq] (the commanded acceleration over the period)"""
    def clear_cloud(self) -> None:
        """forgets the last cloud's obstacles and tracks"""
    def set_cloud_options(self, *, voxel_size: float = 0.02, self_filter_margin: float = 0.01,
                          point_margin: float = 0.02, min_cluster_voxels: int = 2, max_obstacles: int = 8,
                          workspace: Optional[ArrayLike] = None) -> None:
        """how clouds become obstacles (docs/perception.md); forgets the last cloud"""
    @property
    def cloud_stats(self) -> dict[str, Any]:
        """what the last cloud became: points in, dropped (non-finite, outside the workspace crop: the box), voxels,
        the robot's voxels, clusters; {} before the first cloud"""
    @property
    def cloud_points(self) -> FloatArray:
        """the last cloud's kept points [M, 3], world frame"""
    @property
    def cloud_obstacles(self) -> list[dict[str, Any]]:
        """the last cloud's obstacles: centroid [3], velocity [3], voxels, track"""

def load_controller(policy_file: str, robot: Union[Robot, str, None] = None, max_obstacles: int = 16,
                    floor_height: Optional[float] = None) -> Controller:
    """the learned controller of a controller file (.rmpp) on `robot` (default: the file's robot)"""
def read_point_cloud(path: str) -> FloatArray:
    """the points [N, 3] of a .ply or .pcd file, in the file's frame and units"""
def rmpflow(robot: Union[Robot, str], max_obstacles: int = 16, config: Optional[str] = None) -> Controller:
    """RMPflow on `robot` with its configs/rmpflow settings (or an RMPflow YAML)"""

def plan_and_react(robot: Union[Robot, str], layer: str = "rmpflow", max_obstacles: int = 16,
                   planning_budget: float = 1.0, planning_iterations: int = 0, safety_margin: float = 0.01,
                   seed: int = 0, floor_height: Optional[float] = None,
                   plan_beside_loop: bool = False) -> Controller:
    """a global joint path (RRT-Connect) to the scene's joint_target followed by the reactive layer ('rmpflow' or a
    controller file), replanning when stalled or blocked; a floor only when floor_height is given; plan_beside_loop:
    plans run on a worker thread and no update() waits for one; update()'s info['plan'] says whether a path is
    followed and whether a plan is in flight"""
def read_planning_scene(path: str, robot: Union[Robot, str, None] = None) -> dict[str, FloatArray]:
    """a MoveIt planning scene's collision objects as update()'s keyword arguments (spheres, boxes, box_rotations,
    cylinders, cylinder_rotations; only the kinds present)"""
def read_motion_plan_request(path: str, robot: Union[Robot, str]) -> dict[str, Any]:
    """a MoveIt motion-plan request in the robot's joint order: start [nq], joint_target [nq], tolerance [nq], group"""

class VecEnv:
    """The batched C++ engine (use rmpmarl.make_vec_env). Arrays are read-only views, overwritten by step/reset."""
    def __init__(self, task: str, num_envs: int, robot: Optional[str] = None, collision: Optional[str] = None,
                 interface: Optional[str] = None, overrides: str = "", num_threads: int = 1, seed: int = 0,
                 autoreset: str = "next-step") -> None: ...
    @property
    def spec(self) -> dict[str, Any]: ...
    @property
    def task_yaml(self) -> str: ...
    def reset(self, seed: Optional[int] = None) -> None: ...
    def step(self, actions: Float32Array) -> None: ...
    @property
    def obs(self) -> Float32Array: ...
    @property
    def state(self) -> Float32Array: ...
    @property
    def rewards(self) -> Float32Array: ...
    @property
    def reward_terms(self) -> Float32Array: ...
    @property
    def terminated(self) -> npt.NDArray[np.bool_]: ...
    @property
    def truncated(self) -> npt.NDArray[np.bool_]: ...
    @property
    def option_started(self) -> Float32Array: ...
    @property
    def final_obs(self) -> Float32Array: ...
    @property
    def final_state(self) -> Float32Array: ...
    def episode_metrics(self) -> dict[str, npt.NDArray[Any]]: ...

class Policy:
    """A controller file's actor through the torch-free runtime. One Policy per thread."""
    def __init__(self, policy_file: str) -> None: ...
    @property
    def path(self) -> str: ...
    @property
    def obs_dim(self) -> int: ...
    @property
    def action_size(self) -> int: ...
    @property
    def head_size(self) -> int: ...
    @property
    def num_options(self) -> int: ...
    @property
    def task_yaml(self) -> str: ...
    @property
    def provenance_yaml(self) -> str: ...
    @property
    def card(self) -> str: ...
    def act(self, obs: Float32Array) -> Float32Array:
        """deterministic actions [B, action_size] for observations [B, obs_dim]"""
    def head(self, obs: Float32Array) -> Float32Array:
        """raw network outputs [B, head_size]"""

def shipped_robots() -> list[str]: ...
def task_names() -> list[str]: ...
def models_directory() -> str: ...
