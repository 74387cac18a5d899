"""A surface mesh from a merged cloud, and the PLY / GLB files of clouds and meshes."""

from __future__ import annotations

import enum
import os
import tempfile
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import open3d as o3d
import trimesh

from fusion.errors import BadInputError, RecordingError
from fusion.frames import T_YUP_ZUP
from fusion.io.atomic import write_bytes_atomic
from fusion.merge.cloud import MergedCloud
from fusion.transforms import apply

_BALL_RADII_SPACINGS = (1.5, 3.0, 6.0)
"""Default ball-pivoting radii, in mean nearest-neighbour spacings of the cloud."""


_MIN_MESH_POINTS = 10


_PALETTE = np.array(
    [[31, 119, 180], [255, 127, 14], [44, 160, 44], [214, 39, 40], [148, 103, 189],
     [140, 86, 75], [227, 119, 194], [127, 127, 127], [188, 189, 34], [23, 190, 207]],
    dtype=np.uint8,
)
"""Export colour of camera ``i``: ``_PALETTE[i % 10]`` (matplotlib's tab10)."""


class MeshMethod(enum.Enum):
    """Surface reconstruction of :func:`mesh_from_cloud` (Open3D)."""

    POISSON = "poisson"
    """Screened Poisson reconstruction (Kazhdan and Hoppe 2013): a closed surface, trimmed where the
    points are sparse."""
    BALL_PIVOTING = "ball_pivoting"
    """Ball pivoting (Bernardini et al. 1999): triangles between the points themselves, holes stay."""


def mesh_from_cloud(
    cloud: MergedCloud,
    *,
    method: MeshMethod = MeshMethod.POISSON,
    depth: int = 8,
    trim_quantile: float = 0.02,
    ball_radii_m: Sequence[float] | None = None,
) -> trimesh.Trimesh:
    """Reconstruct a triangle mesh from a merged cloud with normals.

    Parameters
    ----------
    cloud : a merged cloud with normals oriented outward (as :func:`merge_clouds` gives them).
    method : POISSON or BALL_PIVOTING.
    depth : octree depth of POISSON (grid resolution at most 2**depth over the cloud's extent).
    trim_quantile : POISSON only: the vertices whose density (Open3D's measure of how many input
        points support them) is below this quantile of all densities are removed with their
        triangles: the surface Poisson invents far from the points. 0 keeps the closed surface.
    ball_radii_m : BALL_PIVOTING only: ball radii [m]; default 1.5, 3 and 6 times the mean
        nearest-neighbour spacing of the points.

    Returns
    -------
    trimesh.Trimesh
        Vertices [m] in the world frame. POISSON results are not reproducible bit for bit: Open3D's
        reconstruction varies in the last digits from run to run.

    Raises
    ------
    BadInputError
        No normals, fewer than 10 points, or malformed parameters.
    """
    if not isinstance(method, MeshMethod):
        raise BadInputError(f"method must be a MeshMethod, one of {[m.name for m in MeshMethod]}, got {method!r}")
    if cloud.normals is None:
        raise BadInputError("the cloud has no normals; merge it with with_normals=True")
    if cloud.n_points < _MIN_MESH_POINTS:
        raise BadInputError(f"a mesh needs at least {_MIN_MESH_POINTS} points, the cloud has {cloud.n_points}")
    pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(cloud.points.copy()))
    pcd.normals = o3d.utility.Vector3dVector(cloud.normals.copy())
    if method is MeshMethod.POISSON:
        if not 1 <= depth <= 16:
            raise BadInputError(f"depth must lie in 1..16, got {depth}")
        if not (np.isfinite(trim_quantile) and 0 <= trim_quantile < 1):
            raise BadInputError(f"trim_quantile must lie in [0, 1), got {trim_quantile}")
        # one thread: Open3D's multi-threaded Poisson crashes at random (isl-org/Open3D#6828; a test process
        # here died in it once) and gives slightly different meshes from run to run (isl-org/Open3D#2117)
        mesh, densities = o3d.geometry.TriangleMesh.create_from_point_cloud_poisson(pcd, depth=depth, n_threads=1)
        densities = np.asarray(densities)
        if trim_quantile > 0:
            mesh.remove_vertices_by_mask(densities < np.quantile(densities, trim_quantile))
    else:
        if ball_radii_m is None:
            spacing = float(np.mean(np.asarray(pcd.compute_nearest_neighbor_distance())))
            radii = [k * spacing for k in _BALL_RADII_SPACINGS]
        else:
            radii = [float(r) for r in ball_radii_m]
            if not radii or not all(np.isfinite(r) and r > 0 for r in radii):
                raise BadInputError(f"ball_radii_m must be non-empty and positive, got {ball_radii_m}")
        mesh = o3d.geometry.TriangleMesh.create_from_point_cloud_ball_pivoting(pcd, o3d.utility.DoubleVector(radii))
    return trimesh.Trimesh(np.asarray(mesh.vertices), np.asarray(mesh.triangles))


def _colours(cloud: MergedCloud) -> np.ndarray:
    """(N, 3) uint8 RGB export colours, one palette colour per camera."""
    return _PALETTE[cloud.camera_index % len(_PALETTE)]


def export_ply(cloud: MergedCloud, path: str | os.PathLike) -> Path:
    """Write a merged cloud as a binary PLY file, atomically; returns the path.

    Per vertex: ``x, y, z`` and, if present, ``nx, ny, nz`` as doubles [m]; ``red, green, blue``
    (one colour per camera); ``camera`` (int, the index into ``cloud.camera_names``).

    Raises
    ------
    BadInputError
        The cloud has no points (Open3D writes no empty PLY).
    """
    if cloud.n_points == 0:
        raise BadInputError("the cloud has no points; there is nothing to export")
    pcd = o3d.t.geometry.PointCloud(o3d.core.Tensor(cloud.points))
    if cloud.normals is not None:
        pcd.point.normals = o3d.core.Tensor(cloud.normals)
    pcd.point.colors = o3d.core.Tensor(_colours(cloud))
    pcd.point.camera = o3d.core.Tensor(cloud.camera_index.astype(np.int32)[:, None])
    with tempfile.TemporaryDirectory() as tmp:
        tmp_path = os.path.join(tmp, "cloud.ply")
        if not o3d.t.io.write_point_cloud(tmp_path, pcd):
            raise RecordingError(f"Open3D could not write the PLY for {path}")
        data = Path(tmp_path).read_bytes()
    write_bytes_atomic(path, data)
    return Path(path)


def export_glb(geometry: MergedCloud | trimesh.Trimesh, path: str | os.PathLike) -> Path:
    """Write a merged cloud (points coloured by camera) or a mesh as binary glTF, atomically; returns the path.

    glTF is y up: the z-up world frame is written as ``(X, Y, Z) = (x, z, -y)`` [m], so the body
    stands upright in every viewer.

    Raises
    ------
    BadInputError
        Neither a MergedCloud nor a trimesh.Trimesh, or nothing to export (no points, no faces).
    """
    if isinstance(geometry, MergedCloud):
        if geometry.n_points == 0:
            raise BadInputError("the cloud has no points; there is nothing to export")
        scene = trimesh.Scene(trimesh.PointCloud(apply(T_YUP_ZUP, geometry.points), colors=_colours(geometry)))
    elif isinstance(geometry, trimesh.Trimesh):
        if len(geometry.faces) == 0:
            raise BadInputError("the mesh has no faces; there is nothing to export")
        scene = trimesh.Scene(geometry.copy().apply_transform(T_YUP_ZUP))
    else:
        raise BadInputError(f"export_glb takes a MergedCloud or a trimesh.Trimesh, got {type(geometry).__name__}")
    write_bytes_atomic(path, scene.export(file_type="glb"))
    return Path(path)


def load_ply(path: str | os.PathLike) -> np.ndarray:
    """(N, 3) float64 vertex positions [m] of a PLY file (a cloud from :func:`export_ply`, or a mesh).

    Raises
    ------
    RecordingError
        The file does not exist or is not a readable PLY file.
    """
    path = Path(path)
    if not path.is_file():
        raise RecordingError(f"PLY file {path} does not exist")
    with path.open("rb") as f:
        if f.read(4) != b"ply\n":
            raise RecordingError(f"{path} is not a PLY file (no 'ply' magic line)")
    try:
        geometry = trimesh.load(path, file_type="ply", process=False)
    except (ValueError, KeyError, IndexError, TypeError) as exc:
        raise RecordingError(f"{path} is truncated or corrupt ({type(exc).__name__}: {exc})") from None
    vertices = getattr(geometry, "vertices", np.empty((0, 3)))  # a PLY without vertices loads as an empty Scene
    return np.asarray(vertices, dtype=np.float64).reshape(-1, 3)
