# Type stubs of the compiled module (python/trilevel_module.cpp), for editors and type checkers.
# python/tests/test_stubs.py checks them against the module: the same public names, and for every
# function and method the same parameters, keyword-only markers and defaults.
from os import PathLike
from typing import Any, Literal, Mapping, Sequence, overload

import numpy as np
from numpy.typing import ArrayLike, NDArray

__version__: str

_Vertices = NDArray[np.float32]  # (m, 3) world units
_Triangles = NDArray[np.uint32]  # (k, 3) vertex indices, counter-clockwise seen from outside
_Stats = dict[str, Any]  # the keys of the CLI's --stats JSON

class Error(RuntimeError):
    """One-line message on bad input or resources."""

class Reconstructor:
    """Keeps an OpenCL device, its compiled kernels and buffers across frames."""

    def __init__(self, device: int = -1) -> None: ...
    @overload
    def reconstruct(
        self,
        positions: ArrayLike,
        particle_radius: float,
        *,
        mode: Literal["adaptive", "uniform"] = "adaptive",
        cell: float = 1.0,
        kernel_radius: float = 4.0,
        curvature_threshold: float = 0.0,
        level2_tolerance: float = 0.32,
        memory_limit: int = 0,
        level_hysteresis: float = 0.0,
        crack_closing: Literal["collapse", "patches"] = "collapse",
        remove_components_below: float = 0.0,
        particle_box: Sequence[float] | None = None,
        clip_box: Sequence[float] | None = None,
        smooth: bool = False,
        smooth_iterations: int = 0,
        sliver_cleanup: bool = False,
        normals: None = None,
        attributes: None = None,
        return_levels: Literal[False] = False,
    ) -> tuple[_Vertices, _Triangles, _Stats]: ...
    @overload
    def reconstruct(
        self,
        positions: ArrayLike,
        particle_radius: float,
        *,
        mode: Literal["adaptive", "uniform"] = "adaptive",
        cell: float = 1.0,
        kernel_radius: float = 4.0,
        curvature_threshold: float = 0.0,
        level2_tolerance: float = 0.32,
        memory_limit: int = 0,
        level_hysteresis: float = 0.0,
        crack_closing: Literal["collapse", "patches"] = "collapse",
        remove_components_below: float = 0.0,
        particle_box: Sequence[float] | None = None,
        clip_box: Sequence[float] | None = None,
        smooth: bool = False,
        smooth_iterations: int = 0,
        sliver_cleanup: bool = False,
        normals: Literal["gradient", "area"] | None = None,
        attributes: Mapping[str, ArrayLike] | None = None,
        return_levels: bool = False,
    ) -> tuple[Any, ...]: ...
    def reset_history(self) -> None: ...
    @property
    def device(self) -> dict[str, Any]: ...

@overload
def reconstruct(
    positions: ArrayLike,
    particle_radius: float,
    *,
    mode: Literal["adaptive", "uniform"] = "adaptive",
    cell: float = 1.0,
    kernel_radius: float = 4.0,
    curvature_threshold: float = 0.0,
    level2_tolerance: float = 0.32,
    memory_limit: int = 0,
    level_hysteresis: float = 0.0,
    crack_closing: Literal["collapse", "patches"] = "collapse",
    remove_components_below: float = 0.0,
    particle_box: Sequence[float] | None = None,
    clip_box: Sequence[float] | None = None,
    smooth: bool = False,
    smooth_iterations: int = 0,
    sliver_cleanup: bool = False,
    normals: None = None,
    attributes: None = None,
    return_levels: Literal[False] = False,
    device: int = -1,
) -> tuple[_Vertices, _Triangles, _Stats]: ...
@overload
def reconstruct(
    positions: ArrayLike,
    particle_radius: float,
    *,
    mode: Literal["adaptive", "uniform"] = "adaptive",
    cell: float = 1.0,
    kernel_radius: float = 4.0,
    curvature_threshold: float = 0.0,
    level2_tolerance: float = 0.32,
    memory_limit: int = 0,
    level_hysteresis: float = 0.0,
    crack_closing: Literal["collapse", "patches"] = "collapse",
    remove_components_below: float = 0.0,
    particle_box: Sequence[float] | None = None,
    clip_box: Sequence[float] | None = None,
    smooth: bool = False,
    smooth_iterations: int = 0,
    sliver_cleanup: bool = False,
    normals: Literal["gradient", "area"] | None = None,
    attributes: Mapping[str, ArrayLike] | None = None,
    return_levels: bool = False,
    device: int = -1,
) -> tuple[Any, ...]: ...
class FramePipeline:
    """Meshes a sequence's frames on a worker thread while the caller produces the next."""
    def __init__(
        self,
        reconstructor: Reconstructor,
        particle_radius: float,
        *,
        mode: Literal["adaptive", "uniform"] = "adaptive",
        cell: float = 1.0,
        kernel_radius: float = 4.0,
        curvature_threshold: float = 0.0,
        level2_tolerance: float = 0.32,
        memory_limit: int = 0,
        level_hysteresis: float = 0.0,
        crack_closing: Literal["collapse", "patches"] = "collapse",
        remove_components_below: float = 0.0,
        particle_box: Sequence[float] | None = None,
        clip_box: Sequence[float] | None = None,
        smooth: bool = False,
        smooth_iterations: int = 0,
        sliver_cleanup: bool = False,
        normals: Literal["gradient", "area"] | None = None,
    ) -> None: ...
    def push(self, positions: ArrayLike) -> list[tuple[Any, ...]]: ...
    def finish(self) -> list[tuple[Any, ...]]: ...

def devices() -> list[dict[str, Any]]: ...
def default_curvature_threshold() -> float: ...
@overload
def read_particles(path: str | PathLike[str], attributes: None = None, *, drop_invalid: bool = False) -> _Vertices: ...
@overload
def read_particles(
    path: str | PathLike[str], attributes: Sequence[str], *, drop_invalid: bool = False
) -> tuple[_Vertices, dict[str, NDArray[np.float32]]]: ...
def write_particles(path: str | PathLike[str], positions: ArrayLike) -> None: ...
@overload
def read_mesh(
    path: str | PathLike[str], *, return_normals: Literal[False] = False, return_attributes: Literal[False] = False
) -> tuple[_Vertices, _Triangles]: ...
@overload
def read_mesh(path: str | PathLike[str], *, return_normals: bool = False, return_attributes: bool = False) -> tuple[Any, ...]: ...
def write_mesh(
    path: str | PathLike[str],
    vertices: ArrayLike,
    triangles: ArrayLike,
    *,
    vertex_level: ArrayLike | None = None,
    color_levels: bool = False,
    normals: ArrayLike | None = None,
    attributes: Mapping[str, ArrayLike] | None = None,
) -> None: ...
def scene_names() -> list[str]: ...
def generate_scene(name: str, radius: float, seed: int = 1, frame: int = 0) -> _Vertices: ...
