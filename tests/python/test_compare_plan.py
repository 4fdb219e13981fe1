"""The comparison's plan and job schema (docs/compare.md, "The plan and the job"): one list of
paths, one schema version.

What is checked, and against what:
  * `airmass compare --list-paths --json` is the list every other place uses: the plan a
    `--no-blender` run writes into job.json names the same paths, renderers, references and
    titles in the same order; it is compare/plan.json's table field by field (the file the CLI
    is built from, and the add-on's Paths checkboxes and job_schema.py read); the text form
    names each path;
  * the job schema: job.json carries "format" and "schema_version" equal to what the CLI's
    list announces and to compare/job_schema.py's SCHEMA_VERSION (the version the scripts
    read); report.py (system Python) and blender_render.py (headless Blender, skipped without
    it) refuse a job of a foreign schema_version or format with an error naming the field, and
    write nothing;
  * the plan's checks come before any file: a bad option names itself and leaves no output
    folder.
"""

import ast
import importlib.util
import json
import os
import shutil
import subprocess
import sys

import pytest

REPO = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
COMPARE = os.path.join(REPO, "compare")
PROPERTIES = os.path.join(REPO, "addon", "airmass_blender", "properties.py")


def run(cmd, timeout=600):
    return subprocess.run([str(c) for c in cmd], capture_output=True, text=True, timeout=timeout)


def job_schema():
    spec = importlib.util.spec_from_file_location("airmass_job_schema", os.path.join(COMPARE, "job_schema.py"))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def path_list(airmass_bin):
    p = run([airmass_bin, "compare", "--list-paths", "--json"])
    assert p.returncode == 0, p.stderr
    return json.loads(p.stdout)


@pytest.fixture(scope="module")
def no_blender_job(airmass_bin, tmp_path_factory):
    """A 16x9 --no-blender run of every path but POV-Ray's (which would need povray only later,
    but write scenes): the native renders, the inputs, job.json."""
    out = tmp_path_factory.mktemp("plan") / "job"
    p = run([airmass_bin, "compare", "--preset", "earth", "-o", out, "--no-blender", "--width", 16, "--height", 9,
             "--view-samples", 4, "--threads", 2, "-q", "--max-distance", 20,
             "--paths", "sky_texture,analytic_volume,analytic_volume_ms,vdb_volume"])
    assert p.returncode == 0, p.stderr
    with open(os.path.join(out, "job.json")) as f:
        return out, json.load(f)


def test_list_paths_is_the_plans_table(path_list, no_blender_job):
    _, job = no_blender_job
    paths = path_list["paths"]
    assert [p["name"] for p in paths] == [p["name"] for p in job["plan"]["all_paths"]]
    for listed, planned in zip(paths, job["plan"]["all_paths"]):
        for k in ("renderer", "reference", "title"):
            assert listed[k] == planned[k], (listed["name"], k)
    assert {p["renderer"] for p in paths} == {"blender", "povray"}
    # What each path needs: its reference among the native renders it names.
    for p in paths:
        assert p["reference"] in p["natives"], p["name"]
        assert p["modes_option"] in (None, "--volume-modes", "--ms-modes")
        assert isinstance(p["render_count"], str) and p["render_count"]
        assert p["step_cost"] > 0
    # The default --paths: the defaults of the list.
    assert [p["name"] for p in paths if p["default"]] == ["sky_texture", "analytic_volume", "vdb_volume"]


def test_plan_renders_what_the_list_says(path_list, no_blender_job):
    """The run made the native renders the list names for its paths (and those only), in
    the plan's order, and planned a render count for each Blender path."""
    out, job = no_blender_job
    by_name = {p["name"]: p for p in path_list["paths"]}
    want = set()
    for p in job["paths_requested"]:
        want |= set(by_name[p]["natives"])
    assert set(job["plan"]["natives"]) == want
    assert set(job["native"]) == want
    for n in want:
        assert os.path.isfile(os.path.join(out, n + ".exr")), n
    assert set(job["plan"]["blender_renders"]) == set(job["paths_requested"])
    seeds = job["seeds"]
    assert job["plan"]["blender_renders"]["sky_texture"] == seeds["sky_texture"] == 2
    assert job["plan"]["blender_renders"]["analytic_volume_ms"] == \
        seeds["analytic_volume_ms"] * 3 * len(job["multiple"]["modes"])
    assert job["plan"]["steps"][:len(job["plan"]["natives"])] == job["plan"]["natives"]


def test_the_cli_was_built_from_plan_json(path_list):
    """compare/plan.json is the one table: the CLI's list is that file's paths, field by field,
    in its order, and announces its job schema version."""
    with open(os.path.join(COMPARE, "plan.json"), encoding="utf-8") as f:
        plan = json.load(f)
    assert path_list["job_schema_version"] == plan["job_schema_version"]
    listed = path_list["paths"]
    assert [p["name"] for p in listed] == [p["name"] for p in plan["paths"]]
    for got, want in zip(listed, plan["paths"]):
        for k in ("addon_flag", "label", "description", "title", "reference", "renderer", "renders", "default",
                  "step_cost", "render_count"):
            assert got[k] == want[k], (want["name"], k)
        # the natives every run makes, then the path's own
        assert got["natives"][len(got["natives"]) - len(want["natives"]):] == want["natives"], want["name"]
        assert got["volume_modes"] == (want["modes"] == "volume") and got["ms_modes"] == (want["modes"] == "ms")


def test_the_addons_paths_come_from_plan_json():
    """properties.py's Compare Paths checkboxes are built from the zip's compare_scripts/plan.json
    (tests/blender/test_material_graph.py checks the registered items against the CLI's list in
    Blender); neither properties.py nor compare.py names a path itself."""
    props = open(PROPERTIES, encoding="utf-8").read()
    assert 'os.path.join(_PACKAGE_DIR, "compare_scripts", "plan.json")' in props
    tree = ast.parse(props)
    for node in ast.walk(tree):
        if isinstance(node, ast.AnnAssign) and getattr(node.target, "id", None) == "compare_paths":
            kws = {kw.arg: kw.value for kw in node.annotation.keywords}
            assert isinstance(kws["items"], ast.Name) and isinstance(kws["default"], ast.Name), \
                "compare_paths' items and default must come from plan.json, not literals"
            break
    else:
        raise AssertionError("compare_paths not found in properties.py")
    with open(os.path.join(COMPARE, "plan.json"), encoding="utf-8") as f:
        names = [p["name"] for p in json.load(f)["paths"]]
    source = open(os.path.join(REPO, "addon", "airmass_blender", "compare.py"), encoding="utf-8").read()
    for name in names:
        assert '"%s"' % name not in source, "compare.py names path %s itself" % name
        assert '"%s"' % name.upper() not in props, "properties.py names path %s itself" % name


def test_list_paths_text_names_each_path(airmass_bin, path_list):
    p = run([airmass_bin, "compare", "--list-paths"])
    assert p.returncode == 0, p.stderr
    for e in path_list["paths"]:
        assert e["name"] in p.stdout and e["reference"] in p.stdout
    p = run([airmass_bin, "compare", "--preset", "earth", "--json"])
    assert p.returncode != 0 and "--list-paths" in p.stderr


def test_job_carries_the_schema_version_the_scripts_read(path_list, no_blender_job):
    _, job = no_blender_job
    schema = job_schema()
    assert job["format"] == schema.FORMAT
    assert job["schema_version"] == path_list["job_schema_version"] == schema.SCHEMA_VERSION
    assert schema.check(job) is job


def _foreign(out, tmp_path, **fields):
    """A copy of the job folder whose job.json has `fields` replaced (None: removed)."""
    d = tmp_path / "foreign"
    shutil.copytree(out, d)
    with open(d / "job.json") as f:
        job = json.load(f)
    for k, v in fields.items():
        if v is None:
            job.pop(k)
        else:
            job[k] = v
    (d / "job.json").write_text(json.dumps(job))
    return d


@pytest.mark.parametrize("fields, named", [({"schema_version": 99}, "schema_version"),
                                           ({"schema_version": None}, "schema_version"),
                                           ({"format": "airmass-compare-job-1"}, "format")])
def test_report_refuses_a_foreign_job(no_blender_job, tmp_path, fields, named):
    pytest.importorskip("numpy")
    out, _ = no_blender_job
    d = _foreign(out, tmp_path, **fields)
    p = run([sys.executable, os.path.join(COMPARE, "report.py"), d], timeout=120)
    assert p.returncode != 0
    assert 'field "%s"' % named in p.stderr, p.stderr
    assert not (d / "summary.json").exists() and not (d / "report.md").exists()


@pytest.mark.skipif(shutil.which("blender") is None, reason="blender is not installed")
def test_blender_render_refuses_a_foreign_job(no_blender_job, tmp_path):
    out, _ = no_blender_job
    d = _foreign(out, tmp_path, schema_version=1)
    p = run([shutil.which("blender"), "-b", "--factory-startup", "--python-exit-code", "1", "--python",
             os.path.join(COMPARE, "blender_render.py"), "--", d / "job.json", "sky_texture"], timeout=300)
    assert p.returncode != 0
    assert 'field "schema_version" is 1' in p.stdout + p.stderr, p.stdout[-2000:] + p.stderr[-2000:]
    assert not (d / "blender_sky_texture.json").exists()


@pytest.mark.parametrize("option, value", [("--seeds", "1"), ("--sky-samples", "0"), ("--paths", "sky"),
                                           ("--volume-modes", "grey"), ("--ms-modes", ""), ("--step", "0")])
def test_a_bad_option_is_refused_before_any_file(airmass_bin, tmp_path, option, value):
    out = tmp_path / "never"
    p = run([airmass_bin, "compare", "--preset", "earth", "-o", out, "--no-blender", option, value])
    assert p.returncode != 0 and option in p.stderr, p.stderr
    assert not out.exists()
