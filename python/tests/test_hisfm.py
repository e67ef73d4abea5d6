"""The Python module `hisfm` against the `hisfm` command: same results, same
one-line errors, options by keyword, arrays where natural."""
import json
import os
import shutil
import stat
from pathlib import Path

import numpy as np
import pytest

import hisfm
from conftest import cli_error, run_hisfm


def test_module_metadata():
    code, stdout, _ = run_hisfm("--version")
    assert code == 0
    assert stdout.strip() == "hisfm " + hisfm.__version__
    assert issubclass(hisfm.Error, RuntimeError)


def test_view_graph_matches_the_command(scene):
    database = scene / "database.db"
    graph = hisfm.view_graph(database, top_k=1, log_level="warn")
    code, stdout, stderr = run_hisfm("view_graph", "--database_path", database,
                                     "--HiSfM.top_k", 1, "--log_level", "warn")
    assert code == 0, stderr
    expected = json.loads(stdout)

    ids = graph["image_ids"]
    assert isinstance(ids, np.ndarray) and ids.shape == (24,)
    communities = graph["communities"]
    assert isinstance(communities, np.ndarray)
    assert communities.dtype.kind == "i" and communities.shape == (24,)
    assert ids.tolist() == [im["image_id"] for im in expected["images"]]
    assert communities.tolist() == [im["community"] for im in expected["images"]]
    assert graph["skeletal"].dtype == bool
    assert graph["skeletal"].tolist() == [im["skeletal"] for im in expected["images"]]
    assert graph["image_names"] == [im["name"] for im in expected["images"]]
    assert graph["num_communities"] == expected["num_communities"] > 1

    for key in ("skeleton_bridges", "rejected_bridges", "skeleton_intra_edges",
                "leaf_edges", "support_edges", "rejected_trusted_edges"):
        pairs = graph[key]["pairs"]
        assert pairs.ndim == 2 and pairs.shape == (len(expected[key]), 2), key
        assert pairs.tolist() == [[e["image_id1"], e["image_id2"]]
                                  for e in expected[key]], key
        assert np.isin(pairs, ids).all()
        assert graph[key]["inliers"].tolist() == [e["inliers"] for e in expected[key]]
    trusted = graph["rejected_trusted_edges"]
    assert trusted["scores"].tolist() == [
        e["score"] for e in expected["rejected_trusted_edges"]]
    assert trusted["rounds"].tolist() == [
        e["round"] for e in expected["rejected_trusted_edges"]]
    bridges = graph["skeleton_bridges"]
    assert bridges["communities"].shape == bridges["pairs"].shape
    assert len(bridges["roles"]) == len(bridges["scores"]) == bridges["pairs"].shape[0]
    # Every image is in exactly one community, bridges join two.
    assert (bridges["communities"][:, 0] != bridges["communities"][:, 1]).all()
    assert graph["summary"]["components"] == expected["summary"]["components"]


def test_bridges_after_the_first_tree_carry_their_cycle_error(scene):
    database = scene / "database.db"
    graph = hisfm.view_graph(database, num_trees=2, log_level="warn")
    code, stdout, stderr = run_hisfm("view_graph", "--database_path", database,
                                     "--HiSfM.num_trees", 2, "--log_level", "warn")
    assert code == 0, stderr
    expected = json.loads(stdout)["skeleton_bridges"]
    bridges = graph["skeleton_bridges"]
    errors = bridges["cycle_errors_deg"]
    assert errors.shape == (len(expected),)
    for error, tree, e in zip(errors, bridges["trees"], expected):
        if tree == 0:
            assert np.isnan(error), "the first tree closes no cycle"
        if "cycle_error_deg" in e:
            assert error == pytest.approx(e["cycle_error_deg"])
            assert 0 <= error <= 45
        else:
            assert np.isnan(error)
    assert (bridges["trees"] == 1).any() and not np.isnan(errors).all()


def test_options_by_keyword_change_the_result(scene):
    database = scene / "database.db"
    one = hisfm.view_graph(database, top_k=1, log_level="warn")
    two = hisfm.view_graph(database, top_k=2, verifier="none", log_level="warn")
    assert two["num_communities"] <= one["num_communities"]
    assert len(two["rejected_bridges"]["pairs"]) == 0


def test_keyword_errors_name_the_option(scene):
    database = scene / "database.db"
    with pytest.raises(TypeError, match="top_kk"):
        hisfm.view_graph(database, top_kk=1)
    with pytest.raises(ValueError, match="top_k"):
        hisfm.view_graph(database, top_k="many")
    with pytest.raises(ValueError, match="top_k"):
        hisfm.view_graph(database, top_k=[1])
    with pytest.raises(TypeError, match="verdict"):
        hisfm.evaluate(scene / "ground_truth", scene / "ground_truth",
                       verdict=5)


def test_errors_carry_the_commands_one_line_message(scene, tmp_path):
    database = scene / "database.db"
    with pytest.raises(hisfm.Error) as error:
        hisfm.view_graph(database, top_k=0)
    assert str(error.value) == cli_error("view_graph", "--database_path",
                                         database, "--HiSfM.top_k", 0)
    assert "top_k" in str(error.value)

    missing = tmp_path / "missing.db"
    with pytest.raises(hisfm.Error) as error:
        hisfm.view_graph(missing)
    assert str(error.value) == cli_error("view_graph", "--database_path",
                                         missing)
    not_a_database = tmp_path / "notes.db"
    not_a_database.write_text("not SQLite\n")
    with pytest.raises(hisfm.Error) as error:
        hisfm.view_graph(not_a_database)
    assert str(error.value) == cli_error("view_graph", "--database_path",
                                         not_a_database)
    assert "\n" not in str(error.value)

    with pytest.raises(hisfm.Error) as error:
        hisfm.mapper(database, scene / "images", tmp_path / "out",
                     scaffold_ba_global_ratio=0.5)
    assert str(error.value) == cli_error(
        "mapper", "--database_path", database, "--image_path",
        scene / "images", "--output_path", tmp_path / "out2",
        "--HiSfM.scaffold_ba_global_ratio", 0.5)
    assert not (tmp_path / "out").exists()


def test_evaluate_returns_per_image_errors(scene):
    truth = scene / "ground_truth"
    result = hisfm.evaluate(truth, truth)
    code, stdout, _ = run_hisfm("evaluate", "--model", truth, "--reference",
                                truth, "--json")
    assert code == 0
    expected = json.loads(stdout)
    assert result["correct"] is True and expected["correct"] is True
    per_image = result["largest"]["per_image"]
    assert per_image["names"] == expected["largest"]["per_image"]["names"]
    assert len(per_image["names"]) == 24
    for key in ("center_error", "rotation_error_deg"):
        assert isinstance(per_image[key], np.ndarray)
        assert per_image[key].shape == (24,)
        assert np.all(per_image[key] < 1e-6), key
    assert result["model_paths"] == [str(truth)]


def write_fake_colmap(path, version_line):
    path.write_text("#!/bin/sh\necho '" + version_line + "'\n")
    path.chmod(path.stat().st_mode | stat.S_IXUSR)
    return path


def test_unknown_colmap_release_is_refused(scene, tmp_path):
    colmap = write_fake_colmap(tmp_path / "colmap",
                               "COLMAP 4.7.0 (Commit 0 on 2030-01-01)")
    with pytest.raises(hisfm.Error, match="unsupported COLMAP version 4.7.0"):
        hisfm.mapper(scene / "database.db", scene / "images", tmp_path / "out",
                     colmap_path=colmap)
    assert not (tmp_path / "out").exists()


@pytest.mark.skipif(shutil.which("colmap") is None,
                    reason="colmap is not installed (scripts/setup.sh)")
def test_mapper_reconstructs_and_returns_poses(scene, tmp_path):
    out = tmp_path / "out"
    summary = hisfm.mapper(scene / "database.db", scene / "images", out,
                           log_level="warn",
                           mapper_options={"ba_global_max_num_iterations": 30})
    assert summary["registered_images"] == 24
    with open(out / "hisfm_summary.json") as f:
        assert json.load(f)["registered_images"] == 24
    assert (out / "report.html").exists()
    assert "Mapper.ba_global_max_num_iterations=30" in (
        out / "hisfm_options.ini").read_text()
    poses = summary["models"][0]["poses"]
    assert poses["rotations"].shape == (24, 4)
    assert poses["centers"].shape == (24, 3)
    assert np.allclose(np.linalg.norm(poses["rotations"], axis=1), 1.0)
    result = hisfm.evaluate(out, scene / "ground_truth")
    assert result["correct"], result["verdict_reason"]
    assert np.nanmax(result["largest"]["per_image"]["rotation_error_deg"]) < 5


def test_shared_scene_view_graph():
    data = Path(os.environ.get("HISFM_DATA_DIR",
                               Path(__file__).resolve().parents[3] / "shared/data"))
    database = data / "yan2017/cup/database.db"
    if not database.exists():
        pytest.skip(f"shared data not found: {database} (set HISFM_DATA_DIR)")
    graph = hisfm.view_graph(database, log_level="warn")
    assert graph["communities"].shape == graph["image_ids"].shape
    assert graph["num_images"] == len(graph["image_ids"])


def colmap_children(pid):
    """The colmap processes started by process `pid`."""
    try:
        with open(f"/proc/{pid}/task/{pid}/children") as f:
            children = f.read().split()
    except OSError:
        return []
    found = []
    for child in children:
        try:
            with open(f"/proc/{child}/comm") as f:
                if f.read().strip() == "colmap":
                    found.append(int(child))
        except OSError:
            pass
    return found


@pytest.mark.skipif(shutil.which("colmap") is None,
                    reason="colmap is not installed (scripts/setup.sh)")
def test_ctrl_c_stops_the_mapper_and_colmap(scene, tmp_path):
    import signal
    import subprocess
    import sys
    import time
    out = tmp_path / "out"
    script = (
        "import hisfm\n"
        "try:\n"
        f"    hisfm.mapper({str(scene / 'database.db')!r}, "
        f"{str(scene / 'images')!r}, {str(out)!r}, log_level='warn')\n"
        "    print('finished')\n"
        "except KeyboardInterrupt:\n"
        "    print('KeyboardInterrupt')\n")
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path))

    def default_sigint():
        # A test run started in the background (`cmd &` in a script) ignores
        # SIGINT, and an ignored signal stays ignored in the child, by design
        # (util/interrupt.h); a user's Ctrl-C reaches a foreground process.
        signal.signal(signal.SIGINT, signal.SIG_DFL)

    process = subprocess.Popen([sys.executable, "-c", script], env=env,
                               stdout=subprocess.PIPE, text=True,
                               preexec_fn=default_sigint)
    # Interrupt while colmap runs (the scaffold's mapper).
    children = []
    deadline = time.monotonic() + 120
    while not children and process.poll() is None and time.monotonic() < deadline:
        children = colmap_children(process.pid)
        time.sleep(0.005)
    assert children, "the mapper ended before colmap was seen"
    process.send_signal(signal.SIGINT)
    stdout, _ = process.communicate(timeout=120)
    assert stdout.strip() == "KeyboardInterrupt"
    for child in children:
        assert not os.path.exists(f"/proc/{child}") or \
            open(f"/proc/{child}/stat").read().split()[2] == "Z"
    assert not out.exists()
