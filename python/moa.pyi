"""moa: robot velocity and pose from the counts of several optical mouse sensors.

Units are SI (m, s, rad); poses are world_T_robot (x, y, theta), twists are in
the robot frame (vx, vy in m/s, omega in rad/s). See docs/python.md.
"""
import os
from typing import Any, Optional, Sequence, TypedDict, Union

import numpy as np
import numpy.typing as npt

__version__: str

PathLike = Union[str, os.PathLike[str]]
FloatArray = npt.NDArray[np.float64]

class Error(RuntimeError):
    """A file, option or data error, with the message the `moa` command prints."""

class Config:
    """A robot config v1: Config(path) reads it; Config.from_yaml(text) parses text."""

    def __init__(self, path: PathLike) -> None: ...
    @staticmethod
    def from_yaml(text: str, source: str = "<yaml>") -> Config: ...
    @property
    def names(self) -> list[str]:
        """Sensor names, in config order."""
    @property
    def path(self) -> str: ...
    def to_yaml(self) -> str:
        """The config as YAML text (what `moa calibrate --out` writes)."""
    def to_dict(self) -> dict[str, Any]:
        """The sensors as arrays and the optional blocks (imu): see read_config."""
    def __len__(self) -> int: ...

ConfigLike = Union[PathLike, Config]

class RunSummary:
    """What an odometry run did (the "summary" of odometry()'s result)."""

    epochs: int
    epochs_by_source: dict[str, int]  # mice, wheels, hold
    sensor_epochs: dict[str, int]  # used, or the reason of the exclusion
    fixes: dict[str, int]  # applied, rejected, too_old, invalid
    gyro_epochs: int  # epochs with a gyro reading (imu rows of diagnostics.csv)
    heading_from_gyro: int  # epochs whose heading (rotation) was the gyro's
    gyro: dict[str, float] | None  # bias, bias_sd (rad/s), scale, scale_sd, latency, latency_sd (s) after the last epoch
    warnings: list[str]
    usable: bool  # at least one epoch, at most 1 % of them held
    def verdict(self) -> str: ...
    def text(self) -> str:
        """What `moa odometry` prints."""

class Steps(TypedDict, total=False):
    """Odometry steps, one row per epoch: the columns of odometry.csv."""

    summary: RunSummary  # odometry() only

    t: FloatArray  # s, epoch end
    x: FloatArray  # m, world frame
    y: FloatArray  # m
    theta: FloatArray  # rad
    vx: FloatArray  # m/s, robot frame
    vy: FloatArray  # m/s
    omega: FloatArray  # rad/s
    sd_vx: FloatArray  # m/s, 1-sigma
    sd_vy: FloatArray  # m/s
    sd_omega: FloatArray  # rad/s
    source: npt.NDArray[np.str_]  # mice, wheels, hold
    heading: npt.NDArray[np.str_]  # gyro (the rotation was the gyro's), else the source
    gyro_test: FloatArray  # the gyro's test ratio (1: the gate); NaN: not tested
    used: npt.NDArray[np.bool_]  # (K, N)
    excluded: npt.NDArray[np.str_]  # (K, N): '' when used, else e.g. 'inconsistent/over-speed'
    noise_flags: npt.NDArray[np.uint8]  # (K, N): 1 over-speed, 2 low-squal, 4 overflow
    names: list[str]
    pxx: FloatArray  # m^2, with fuse_camera
    pxy: FloatArray  # m^2
    pyy: FloatArray  # m^2
    ptt: FloatArray  # rad^2
    scale_v: FloatArray  # 1, with fuse_camera and ekf_scale
    scale_omega: FloatArray  # 1
    sd_scale_v: FloatArray  # 1
    sd_scale_omega: FloatArray  # 1

def read_config(path: PathLike) -> dict[str, Any]:
    """Reads a robot config v1 into arrays.

    Returns names (list of str), position (N, 2) m robot frame, yaw (N,) rad,
    cpi (N,), scale (N, 2), mirrored (N,) bool, max_speed (N,) m/s and noise
    (N,) m/s (NaN where the config gives none), latency (N,) s, camera_latency
    and wheels_latency (s, None where the config gives none), imu (the imu:
    block, a dict with its YAML keys scale, bias, noise_density,
    bias_random_walk, bias_sigma, scale_sigma, mount_yaw_sigma, max_rate,
    latency; None where the config has no imu: block).
    """

def read_log(config: ConfigLike, log_dir: PathLike) -> dict[str, Any]:
    """Reads a log directory (or its mice.csv) into arrays.

    "mice": t (s), sensor (index in the config), dx, dy (counts, sensor
    frame), squal (-1 where absent), flags; for the files present "wheels":
    t, vx, vy, omega; "imu": t, gz (rad/s, as imu.csv holds it); "camera": t,
    x, y, theta, sx, sy (NaN where absent); "truth": t, x, y, theta; and
    "names".
    """

def odometry(
    config: ConfigLike,
    log_dir: PathLike,
    estimator: str = "consensus",
    *,
    sensors: Optional[Sequence[str]] = None,
    rate: float = 100.0,
    no_wheels: bool = False,
    fuse_camera: bool = False,
    camera_latency: float = 0.0,
    camera_sigma: float = 0.005,
    e_th: Optional[float] = None,
    r_th: Optional[int] = None,
    alpha: Optional[float] = None,
    initial_pose: Optional[Sequence[float]] = None,
    max_row_interval: Optional[float] = None,
    max_gap: float = 3600.0,
    ekf_scale: bool = False,
) -> Steps:
    """Runs `moa odometry` on a log; returns its columns as arrays (equal to odometry.csv).

    estimator: ls, sekimori, consensus, wheels or oracle. The options are the
    command's flags: sensors (names), rate (Hz), no_wheels, fuse_camera,
    camera_latency (s), camera_sigma (m), e_th (m^2), r_th, alpha,
    initial_pose (x, y, theta), max_row_interval (s; default 0.05, or 60
    epochs where that is shorter), max_gap (s), ekf_scale.
    """

class Odometry:
    """The odometry pipeline, fed row by row or in bulk, in time order.

    Each call returns the steps that became ready, as a dict of arrays like
    odometry()'s (possibly empty).
    """

    def __init__(
        self, config: ConfigLike, t0: float = 0.0, estimator: str = "consensus", **options: Any
    ) -> None: ...
    def push(
        self,
        t: float,
        sensor: Union[int, str],
        dx: float,
        dy: float,
        squal: Optional[int] = None,
        flags: int = 0,
    ) -> Steps:
        """A mice row: time (s), sensor (name or index), counts (sensor frame), squal (None or -1: absent), flags."""
    def push_rows(
        self,
        t: npt.ArrayLike,
        sensor: npt.ArrayLike,
        dx: npt.ArrayLike,
        dy: npt.ArrayLike,
        squal: Optional[npt.ArrayLike] = None,
        flags: Optional[npt.ArrayLike] = None,
    ) -> Steps:
        """Mice rows in bulk: arrays of one length (sensor: indices or names; squal: -1 where absent)."""
    def push_wheels(self, t: float, vx: float, vy: float, omega: float) -> Steps:
        """A wheel-odometry row: the twist (robot frame) averaged since the previous one."""
    def push_fix(
        self,
        t: float,
        x: float,
        y: float,
        theta: Optional[float] = None,
        sx: Optional[float] = None,
        sy: Optional[float] = None,
    ) -> None:
        """A camera fix captured at t: position (world frame, m), heading (rad), sd (m)."""
    def finish(self, t_end: float) -> Steps:
        """Ends the stream at t_end (the last row's time): the remaining steps."""
    @property
    def pose(self) -> tuple[float, float, float]:
        """(x, y, theta) of the last step."""
    @property
    def steps(self) -> int:
        """Steps emitted so far."""
    @property
    def names(self) -> list[str]: ...

class Calibration:
    """The result and report of calibrate()."""

    @property
    def method(self) -> str: ...
    @property
    def usable(self) -> bool:
        """The solve converged and the data determined what the method estimates."""
    @property
    def termination(self) -> str:
        """converged, not-converged, model-misfit, underdetermined or too-few-measurements."""
    @property
    def sensors(self) -> list[dict[str, Any]]:
        """Per sensor: name, position (2,) m, yaw rad, scale (2,), mirrored, cpi;
        sd_position, sd_yaw, sd_scale (1-sigma, 0 where kept); estimated (the
        observability report: which parameters were estimated); mirror_from_data;
        nominal; residual_rms (m/s); push_misfit (m); information_eigenvalues."""
    @property
    def observability(self) -> list[dict[str, Any]]:
        """Per sensor: name, estimated (which parameters the data determined) and
        information_eigenvalues (exact; below 1 means not excited)."""
    @property
    def facts(self) -> list[str]: ...
    @property
    def warnings(self) -> list[str]: ...
    @property
    def config(self) -> Config:
        """The calibrated config."""
    def to_yaml(self) -> str:
        """The calibrated config as YAML: what `moa calibrate --out` writes."""
    def brief_report(self) -> str: ...
    def full_report(self) -> str:
        """The text report `moa calibrate` prints."""
    def to_json(self) -> str:
        """The report as `moa calibrate --json` prints it (without "out")."""

def calibrate(
    config: ConfigLike,
    log_dir: Optional[PathLike] = None,
    method: str = "exact",
    *,
    max_row_interval: float = 0.05,
    min_interval: Optional[float] = None,
    measurements: Optional[int] = None,
    push_x: Optional[PathLike] = None,
    push_y: Optional[PathLike] = None,
    spin: Optional[PathLike] = None,
    distance: Optional[float] = None,
    turns: Optional[float] = None,
    distance_sd: float = 0.002,
    turn_sd: float = 0.0087,
    centre_sd: float = 0.001,
    heading_sd: float = 0.0044,
    force: bool = False,
    no_imu: bool = False,
    imu_reference: Optional[str] = None,
    reference: Optional[str] = None,
    max_offset: float = 1.0,
    window: float = 0.2,
) -> Calibration:
    """Runs `moa calibrate`: exact (against wheels.csv, or camera.csv with
    reference="camera": motion capture or a ceiling camera's positions, with
    every stream's latency), kimlee (log_dir with wheels.csv) or guided."""

def simulate(scenario: str, seed: int = 1, out: Optional[PathLike] = None) -> dict[str, Any]:
    """Runs the simulator; with out, also writes the log there. Returns arrays:
    mice, wheels, imu (t, gz; empty without a gyro), camera, truth (dicts), config,
    true_config (Config), names."""

def scenarios() -> list[str]:
    """Names of the built-in scenarios."""

def evaluate(
    truth: Union[PathLike, dict[str, Any]], odometry: Union[PathLike, dict[str, Any]]
) -> dict[str, Any]:
    """Max and RMS translation (m) and heading (rad) error against truth (`moa evaluate`)."""
