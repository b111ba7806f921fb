"""Tests of the Python module `pcp` (python/pcp_module.cpp), run by CTest (label "python")."""
import os
import signal
import subprocess
import sys
import textwrap
import threading
import time

import numpy as np
import pytest

import pcp

CENTRE = np.array([5.0, -3.0, 2.0])
RADIUS = 40.0
# A small schedule: seconds per call, enough for a sphere.
QUICK = dict(preset="fast", steps=200, prior_steps=100, resolution=48)


def sphere_points(n=10000, seed=0):
    rng = np.random.default_rng(seed)
    p = rng.normal(size=(n, 3))
    p /= np.linalg.norm(p, axis=1, keepdims=True)
    return CENTRE + RADIUS * p


@pytest.fixture(scope="module")
def sphere_prior(tmp_path_factory):
    """A prior trained once on a sphere (about a second): the tests below that are not about the
    self-prior pass it, which skips that stage and keeps the test command within its budget."""
    path = str(tmp_path_factory.mktemp("prior") / "sphere.prior")
    pcp.train_prior([sphere_points(10000, seed=3)], path, steps=100)
    return path


@pytest.fixture(scope="module")
def sphere_result():
    points = sphere_points()
    stages = []
    vertices, faces, normals = pcp.reconstruct(points, normals=True, progress=lambda s, i, t: stages.append(s), **QUICK)
    return points, vertices, faces, normals, stages


def test_reconstruct_returns_a_mesh_in_the_input_frame(sphere_result):
    points, vertices, faces, _, _ = sphere_result
    assert vertices.dtype == np.float64 and vertices.ndim == 2 and vertices.shape[1] == 3
    assert faces.dtype == np.int32 and faces.shape[1] == 3 and len(faces) > 1000
    assert faces.min() >= 0 and faces.max() < len(vertices)
    radial = np.linalg.norm(vertices - CENTRE, axis=1)
    assert np.abs(radial - RADIUS).max() < 0.02 * RADIUS
    # Outward faces: the signed volume is positive and close to the sphere's.
    tri = vertices[faces]
    volume = np.einsum("ij,ij->i", tri[:, 0] - CENTRE, np.cross(tri[:, 1] - CENTRE, tri[:, 2] - CENTRE)).sum() / 6
    assert volume == pytest.approx(4 / 3 * np.pi * RADIUS**3, rel=0.03)


def test_reconstruct_normals_point_outward(sphere_result):
    points, _, _, normals, _ = sphere_result
    assert normals.shape == points.shape
    assert np.allclose(np.linalg.norm(normals, axis=1), 1.0, atol=1e-6)
    radial = (points - CENTRE) / RADIUS
    assert (np.sum(normals * radial, axis=1) > 0).mean() > 0.99
    assert np.degrees(np.arccos(np.clip(np.sum(normals * radial, axis=1), -1, 1))).mean() < 5


def test_progress_sees_every_stage(sphere_result):
    stages = sphere_result[4]
    for stage in ("prior", "query-net", "sdf-grid"):
        assert stage in stages


def test_float32_input_gives_the_same_kind_of_result(sphere_result):
    # The float64 fixture's schedule (self-prior): with sphere_prior and 100-300 query steps the
    # field is still bumpy on some machines (Zen 4: 12-85 vertices 2-5 units off the sphere).
    points = sphere_result[0].astype(np.float32)
    vertices, faces = pcp.reconstruct(points, **QUICK)
    assert np.abs(np.linalg.norm(vertices - CENTRE, axis=1) - RADIUS).max() < 0.02 * RADIUS
    assert len(vertices) == pytest.approx(len(sphere_result[1]), rel=0.05)


@pytest.mark.parametrize(
    "bad, kind, words",
    [
        (np.zeros((100, 2)), ValueError, "shape (N, 3)"),
        (np.zeros(300), ValueError, "shape (N, 3)"),
        (np.zeros((100, 3), dtype=np.int64), ValueError, "float32 or float64"),
        ([[0.0, 0.0, 0.0]] * 100, ValueError, "numpy array"),
        (np.asfortranarray(sphere_points(1000)), ValueError, "C-contiguous"),
        (sphere_points(1000)[::2], ValueError, "C-contiguous"),
        (np.vstack([sphere_points(1000), [[np.nan, 0, 0]]]), ValueError, "row 1000 is not finite"),
        (sphere_points(20), pcp.Error, "points"),
    ],
)
def test_bad_arrays_raise_a_clear_exception(bad, kind, words):
    with pytest.raises(kind) as info:
        pcp.reconstruct(bad, **QUICK)
    assert words in str(info.value)


def test_bad_options_raise():
    points = sphere_points(2000)
    with pytest.raises(pcp.Error, match="unknown reconstruction preset"):
        pcp.reconstruct(points, preset="slow")
    with pytest.raises(ValueError, match="threads"):
        pcp.reconstruct(points, threads=-1, **QUICK)
    with pytest.raises(pcp.Error, match="nowhere.prior"):
        pcp.reconstruct(points, prior="/nonexistent/nowhere.prior", **QUICK)
    # The library's settings table checks every value, as on the command line.
    with pytest.raises(ValueError, match=r"resolution must be in \[8, 2048\] \(got '4'\)"):
        pcp.reconstruct(points, preset="fast", resolution=4)
    with pytest.raises(ValueError, match=r"winding-near must be in \[0, 100\] \(got '-3'\)"):
        pcp.reconstruct(points, settings={"winding-near": -3}, **QUICK)
    with pytest.raises(ValueError, match="unknown setting 'no-such'"):
        pcp.reconstruct(points, settings={"no-such": 1}, **QUICK)
    with pytest.raises(ValueError, match="sign-repair must be on or off"):
        pcp.reconstruct(points, settings={"sign-repair": "maybe"}, **QUICK)


def test_progress_can_cancel_and_its_exceptions_propagate(sphere_prior):
    points = sphere_points()
    with pytest.raises(pcp.Cancelled):
        pcp.reconstruct(points, progress=lambda s, i, t: s != "prior", **QUICK)
    with pytest.raises(pcp.Cancelled):
        pcp.reconstruct(points, prior=sphere_prior, progress=lambda s, i, t: s != "query-net", **QUICK)

    def boom(stage, step, total):
        if stage == "query-net":
            raise ZeroDivisionError("from the callback")

    with pytest.raises(ZeroDivisionError, match="from the callback"):
        pcp.reconstruct(points, prior=sphere_prior, progress=boom, **QUICK)


def test_the_gil_is_released_while_the_library_works(sphere_prior):
    points = sphere_points()
    ticks = [0]
    stop = threading.Event()

    def count():
        while not stop.is_set():
            ticks[0] += 1
            time.sleep(0.001)

    thread = threading.Thread(target=count)
    thread.start()
    start = time.time()
    pcp.reconstruct(points, prior=sphere_prior, preset="fast", steps=100, resolution=40)
    elapsed = time.time() - start
    stop.set()
    thread.join()
    # With the GIL held for the whole call the counter would stand still; released, it ticks at
    # about 1000 per second (sleep granularity) for the whole call.
    assert ticks[0] > 50 * elapsed


def test_ctrl_c_cancels_a_running_fit(sphere_prior):
    script = textwrap.dedent(
        """
        import sys, numpy as np, pcp
        rng = np.random.default_rng(0)
        p = rng.normal(size=(10000, 3)); p /= np.linalg.norm(p, axis=1, keepdims=True)
        def progress(stage, step, total):
            if stage == "query-net":
                print("fitting", flush=True)
        try:
            pcp.reconstruct(p, preset="fast", steps=100000, prior=sys.argv[1], progress=progress)
        except KeyboardInterrupt:
            print("interrupted", flush=True)
            sys.exit(3)
        """
    )
    child = subprocess.Popen([sys.executable, "-c", script, sphere_prior], stdout=subprocess.PIPE, text=True, env=dict(os.environ))
    assert child.stdout.readline().strip() == "fitting"
    start = time.time()
    child.send_signal(signal.SIGINT)
    out, _ = child.communicate(timeout=60)
    assert child.returncode == 3
    assert "interrupted" in out
    assert time.time() - start < 30


def test_io_round_trip_and_evaluate(tmp_path, sphere_result):
    _, vertices, faces, _, _ = sphere_result
    path = str(tmp_path / "mesh.ply")
    pcp.write_mesh(path, vertices, faces)
    v2, f2 = pcp.read_mesh(path)
    assert np.array_equal(v2, vertices) and np.array_equal(f2, faces)
    metrics = pcp.evaluate((vertices, faces), (v2, f2), samples=2000, floor=True)
    # The same mesh: its error is the sampling floor's (two independent samplings of one surface).
    assert metrics["protocol"] == "p2s"
    assert 0.5 < metrics["chamfer_l2_x100"] / metrics["floor"]["chamfer_l2_x100"] < 2
    assert metrics["normal_consistency"] > 0.99
    with pytest.raises(pcp.Error, match="missing.ply"):
        pcp.read_point_cloud(str(tmp_path / "missing.ply"))
    with pytest.raises(ValueError, match="face 0 names vertex"):
        pcp.write_mesh(str(tmp_path / "bad.ply"), vertices, np.array([[0, 1, len(vertices)]]))
    assert not (tmp_path / "bad.ply").exists()


def test_read_point_cloud_of_shared_data():
    data = os.environ.get("PCP_TEST_DATA", "")
    path = os.path.join(data, "objects", "bunny", "input.ply")
    if not os.path.exists(path):
        pytest.fail("the shared data is missing: " + path)
    points = pcp.read_point_cloud(path)
    assert points.shape == (20000, 3) and points.dtype == np.float64


def test_train_prior_then_reconstruct_with_it(tmp_path):
    output = str(tmp_path / "sphere.prior")
    info = pcp.train_prior([sphere_points(10000, seed=3)], output, steps=100)
    assert info["steps"] == 100 and os.path.exists(output)
    vertices, faces = pcp.reconstruct(sphere_points(10000, seed=4), prior=output, preset="fast", steps=200, resolution=48)
    assert np.percentile(np.abs(np.linalg.norm(vertices - CENTRE, axis=1) - RADIUS), 95) < 0.03 * RADIUS
    with pytest.raises(ValueError, match="at least one"):
        pcp.train_prior([], output)
