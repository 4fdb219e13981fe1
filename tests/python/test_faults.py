"""Faults with nothing lost (issue 17 item 4; docs/reliability.md, "Faults").

Every file-writing command of the CLI, with a previous result already in its folder, meets
each fault while it writes:

  * unwritable   the folder is read-only (a read-only tmpfs when run as root, mode 0555 else);
  * fsize        a file-size limit (RLIMIT_FSIZE, `ulimit -f`) smaller than any output: the
                 write fails with EFBIG (the CLI ignores SIGXFSZ for that);
  * enospc       a full disk: a tmpfs just larger than the previous result (root only);
  * sigint       Ctrl-C while a temporary is being written (the process is stopped with
                 SIGSTOP once a temporary holds data, sent SIGINT, continued);
  * kill9        SIGKILL at the same moment, then the same command again.

After each: every target path holds its previous bytes or a complete new file (an EXR that
reads whole at the new size) — never a part; no temporary is left, except after kill -9 the
killed process's own `.<stem>.airmass-tmp-<pid>-<n><ext>`, which the next run removes.
`airmass compare -o DIR` publishes a folder: its writer here puts DIR = <folder>/cmp, so the
fault hits the folder that holds DIR and its staging folder `.cmp.airmass-stage-<pid>` (where
the temporaries are written); after kill -9 that staging folder is what is left.
`airmass sun`, `eval` and `chapman` write to stdout only: a full disk there (/dev/full) must
fail the command. `airmass compare`'s Blender children on SIGINT/SIGKILL: CTest cli_compare_kill.
"""
import contextlib
import ctypes
import os
import pathlib
import re
import resource
import shutil
import signal
import subprocess
import tempfile
import time

import OpenImageIO as oiio
import pytest

TMP_RE = re.compile(r"^\.(?P<stem>.+)\.airmass-tmp-(?P<pid>\d+)-(?P<n>\d+)(?P<ext>\.[A-Za-z0-9]+)?$")
STAGE_RE = re.compile(r"^\.(?P<name>.+)\.airmass-stage-(?P<pid>\d+)$")  # compare's staging folder
SKY = ["--preset", "earth", "--no-multiple", "--basis", "rgb", "--samples", "4", "-q"]
BOX = "-20,-20,0,20,20,10"


# ---- the writers: argv for a folder and a size level (0: the previous result, small;
# ---- 1..3: larger, so that a write lasts long enough to be caught in the middle)
def sky(d, level):
    return ["sky", "-o", d / "sky.exr", "--width", [64, 1024, 2048, 4096][level], *SKY]


def sky_sequence(d, level):
    return ["sky", "-o", d / "f_##.exr", "--time-range", "2026-06-21T06:00:00Z,2026-06-21T06:20:00Z", "--fps",
            "1/600", "--latitude", "48", "--longitude", "11", "--frames-csv", d / "frames.csv",
            "--width", [64, 512, 1024, 2048][level], *SKY]


def render(d, level):
    w = [48, 256, 512, 1024][level]
    return ["render", "--preset", "earth", "-o", d / "r.exr", "--width", w, "--height", w // 2, "--samples", "2",
            "-q"]


def vdb(d, level):
    return ["vdb", "--preset", "earth", "--region", "box", "--box", BOX, "--voxel-size", [4, 0.5, 0.3, 0.2][level],
            "--max-dense-mb", 4096, "-o", d / "a.vdb", "--analytic", d / "a.json", "--pov", d / "a.inc",
            "--df3", d / "a", "-q"]


def compare(d, level):
    w = [64, 256, 512, 1024][level]
    return ["compare", "--preset", "earth", "-o", d / "cmp", "--no-blender", "--width", w, "--height", w * 9 // 16,
            "--view-samples", 2, "--threads", 2, "--paths", "vdb_volume", "--voxel-size", 2, "-q"]


WRITERS = {"sky": sky, "sky_sequence": sky_sequence, "render": render, "vdb": vdb, "compare": compare}
# The writers that stop on Ctrl-C up to the rename (the others finish the file they hold).
HONOURS_CANCEL_WHILE_WRITING = {"render", "vdb", "compare"}


def run(airmass_bin, args, check=True, **kw):
    p = subprocess.run([str(airmass_bin), *map(str, args)], capture_output=True, text=True, timeout=300, **kw)
    if check:
        assert p.returncode == 0, p.stderr
    return p


def _visible_folders(d):
    """d and its sub-folders not hidden, as paths relative to d ("" for d)."""
    out = [""]
    for root, dirs, _ in os.walk(d):
        dirs[:] = [x for x in dirs if not x.startswith(".")]
        out += [os.path.relpath(os.path.join(root, x), d) for x in dirs]
    return out


def temporaries(d):
    """Every temporary-looking name in d and its visible sub-folders (relative to d): ours,
    compare's staging folders, and cmd_sky's CSV's "<name>.tmp-<pid>"."""
    return sorted(os.path.join(f, n) for f in _visible_folders(d) for n in os.listdir(d / f)
                  if ".airmass-tmp-" in n or ".tmp-" in n or ".airmass-stage-" in n or ".airmass-old-" in n)


def snapshot(d):
    """{path relative to d: bytes} of every file not hidden, sub-folders included."""
    return {os.path.join(f, n): (d / f / n).read_bytes() for f in _visible_folders(d) for n in os.listdir(d / f)
            if not n.startswith(".") and (d / f / n).is_file()}


def exr_size(path):
    """(width, height) of an EXR that reads whole, else None."""
    inp = oiio.ImageInput.open(str(path))
    if inp is None:
        return None
    spec = inp.spec()
    pixels = inp.read_image(oiio.FLOAT)
    inp.close()
    return (spec.width, spec.height) if pixels is not None else None


def assert_previous_or_complete(d, before, changed_ok):
    """Each file of `before` is unchanged, or (if changed_ok) a complete new EXR of another size."""
    for name, data in before.items():
        path = d / name
        assert path.exists(), f"{name} removed"
        if path.read_bytes() == data:
            continue
        assert changed_ok and name.endswith(".exr"), f"{name} changed"
        size = exr_size(path)
        assert size is not None, f"{name} is not a complete EXR"


_PREVIOUS = {}


def previous_result(airmass_bin, writer, d):
    """The writer's small result (made once per session), copied into d; returns its bytes."""
    if writer not in _PREVIOUS:
        first = pathlib.Path(tempfile.mkdtemp(prefix="airmass-faults-"))
        run(airmass_bin, WRITERS[writer](first, 0))
        assert temporaries(first) == []
        _PREVIOUS[writer] = snapshot(first)
        shutil.rmtree(first)
    before = _PREVIOUS[writer]
    assert before
    for name, data in before.items():
        (d / name).parent.mkdir(parents=True, exist_ok=True)
        (d / name).write_bytes(data)
    return before


# ---- mounts (root only): a read-only or a small tmpfs
def _can_mount():
    if os.geteuid() != 0:
        return False
    with tempfile.TemporaryDirectory() as t:
        if subprocess.run(["mount", "-t", "tmpfs", "-o", "size=64k", "tmpfs", t], capture_output=True).returncode:
            return False
        subprocess.run(["umount", t], check=True)
    return True


CAN_MOUNT = _can_mount()


@contextlib.contextmanager
def tmpfs(path, size_bytes):
    path.mkdir(exist_ok=True)
    subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size_bytes}", "tmpfs", str(path)], check=True)
    try:
        yield path
    finally:
        subprocess.run(["umount", "-l", str(path)], check=False)


# ---- unwritable folder --------------------------------------------------------------------------
@pytest.mark.parametrize("writer", WRITERS)
def test_unwritable_folder_keeps_the_previous_result(airmass_bin, tmp_path, writer):
    d = tmp_path / "out"
    if CAN_MOUNT:
        ctx = tmpfs(d, 256 << 20)
    elif os.geteuid() != 0:
        d.mkdir()
        ctx = contextlib.nullcontext()
    else:
        pytest.skip("root without mount: no folder is unwritable")
    with ctx:
        before = previous_result(airmass_bin, writer, d)
        if CAN_MOUNT:
            subprocess.run(["mount", "-o", "remount,ro", str(d)], check=True)
        else:
            d.chmod(0o555)
        try:
            p = run(airmass_bin, WRITERS[writer](d, 0), check=False)
        finally:
            if not CAN_MOUNT:
                d.chmod(0o755)
        assert p.returncode != 0
        assert "not writable" in p.stderr, p.stderr
        assert snapshot(d) == before
        assert temporaries(d) == []


# ---- disk full: a file-size limit, and a full tmpfs ---------------------------------------------
def _file_size_limit(nbytes):
    return lambda: resource.setrlimit(resource.RLIMIT_FSIZE, (nbytes, resource.RLIM_INFINITY))


@pytest.mark.parametrize("writer", WRITERS)
def test_file_size_limit_keeps_the_previous_result(airmass_bin, tmp_path, writer):
    d = tmp_path / "out"
    d.mkdir()
    before = previous_result(airmass_bin, writer, d)
    # Half the smallest image or volume: the limit is met in the middle of the first one written.
    limit = min(len(b) for n, b in before.items() if n.endswith((".exr", ".vdb"))) // 2
    # Python ignores SIGXFSZ; subprocess restores the default (terminate) in the child, so the
    # CLI's own handling (ignore it, see EFBIG) is what is tested.
    p = run(airmass_bin, WRITERS[writer](d, 0), check=False, preexec_fn=_file_size_limit(limit))
    assert p.returncode not in (0, -signal.SIGXFSZ), (p.returncode, p.stderr)
    assert str(d) in p.stderr and ("File too large" in p.stderr or "failed" in p.stderr), p.stderr
    assert snapshot(d) == before
    assert temporaries(d) == []


@pytest.mark.skipif(not CAN_MOUNT, reason="needs root and mount (a small tmpfs)")
@pytest.mark.parametrize("writer", WRITERS)
def test_full_disk_keeps_the_previous_result(airmass_bin, tmp_path, writer):
    probe = tmp_path / "probe"
    probe.mkdir()
    before = previous_result(airmass_bin, writer, probe)
    pages = sum(-(-len(b) // 4096) for b in before.values())
    with tmpfs(tmp_path / "out", (pages + 1) * 4096) as d:
        # The previous result fills the disk but for one page.
        for name, data in before.items():
            (d / name).parent.mkdir(parents=True, exist_ok=True)
            (d / name).write_bytes(data)
        p = run(airmass_bin, WRITERS[writer](d, 0), check=False)
        assert p.returncode != 0, "the run fitted: the disk was not full"
        assert str(d) in p.stderr and ("No space left on device" in p.stderr or "failed" in p.stderr), p.stderr
        # Files written before the one that did not fit are complete new ones (identical
        # pixels: the same command), the rest are the previous bytes.
        assert_previous_or_complete(d, before, changed_ok=True)
        assert temporaries(d) == []


# ---- Ctrl-C and kill -9 in the middle of a write -------------------------------------------------
def wait_stopped(pid, seconds=10):
    """Waits until every thread of `pid` is in the stopped state (T) or the process has exited."""
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        try:
            states = []
            for t in os.listdir(f"/proc/{pid}/task"):
                with open(f"/proc/{pid}/task/{t}/stat") as f:
                    states.append(f.read().rsplit(")", 1)[1].split()[0])
        except FileNotFoundError:
            return
        if all(s in "Tt" for s in states) or any(s in "ZX" for s in states):
            return
        time.sleep(0.001)
    pytest.fail(f"process {pid} did not stop within {seconds} s")


def stopped_mid_write(airmass_bin, writer, d, before):
    """Runs the writer at growing sizes until it is caught (and stopped with SIGSTOP) while a
    temporary in `d` holds data. Returns (process, temporary name). A run that finished before
    it was caught has replaced the results: `before` (the previous result) is put back, so
    that `d` holds it again when the caught run starts."""
    for level in (1, 2, 3):
        proc = subprocess.Popen([str(airmass_bin), *map(str, WRITERS[writer](d, level))], stdout=subprocess.PIPE,
                                stderr=subprocess.PIPE, text=True)
        deadline = time.monotonic() + 120
        while proc.poll() is None and time.monotonic() < deadline:
            names = [os.path.relpath(os.path.join(root, n), d) for root, _, files in os.walk(d) for n in files]
            for name in names:
                if ".airmass-tmp-" not in os.path.basename(name):
                    continue
                try:
                    if os.stat(d / name).st_size == 0:
                        continue
                except FileNotFoundError:
                    continue
                proc.send_signal(signal.SIGSTOP)
                # SIGSTOP is delivered asynchronously: until every thread is stopped the writer may
                # still finish and rename the temporary (an uncompressed EXR is written in
                # microseconds). Only a temporary that still exists once the process is stopped
                # was caught in the middle.
                wait_stopped(proc.pid)
                if (d / name).exists():
                    print(f"{writer}: stopped at size level {level} writing {name}")
                    return proc, name
                proc.send_signal(signal.SIGCONT)
        proc.communicate(timeout=120)
        for name in set(snapshot(d)) - set(before):
            os.remove(d / name)
        for name, data in before.items():
            (d / name).write_bytes(data)
    pytest.fail(f"{writer}: no write caught in the middle at any size")


def destination_of(temp):
    """(destination relative to d, pid) of a temporary (relative to d) or a staging folder."""
    folder, name = os.path.split(temp)
    s = STAGE_RE.match(name)
    if s:
        return s["name"], int(s["pid"])
    m = TMP_RE.match(name)
    assert m, f"temporary {temp!r} is not named .<stem>.airmass-tmp-<pid>-<n><ext>"
    s = STAGE_RE.match(folder)  # written in compare's staging folder: its destination is in DIR
    return os.path.join(s["name"] if s else folder, m["stem"] + (m["ext"] or "")), int(m["pid"])


def interrupt_main_thread(pid):
    """SIGINT directed at the main thread of process `pid` (tgkill(pid, pid, SIGINT))."""
    sys_tgkill = {"x86_64": 234, "aarch64": 131}.get(os.uname().machine)
    if sys_tgkill is None:  # elsewhere: to the process (the race above stays possible)
        os.kill(pid, signal.SIGINT)
        return
    libc = ctypes.CDLL(None, use_errno=True)
    if libc.syscall(sys_tgkill, pid, pid, signal.SIGINT) != 0:
        raise OSError(ctypes.get_errno(), "tgkill")


def caught_mid_write(airmass_bin, writer, tmp_path):
    """A previous result in tmp_path/out, and the writer stopped in the middle of a write there:
    (folder, previous bytes, process, temporary, its destination)."""
    d = tmp_path / "out"
    d.mkdir()
    before = previous_result(airmass_bin, writer, d)
    proc, temp = stopped_mid_write(airmass_bin, writer, d, before)
    target, pid = destination_of(temp)
    assert pid == proc.pid
    return d, before, proc, temp, target


@pytest.mark.parametrize("writer", WRITERS)
def test_ctrl_c_while_writing_keeps_the_previous_or_the_complete_file(airmass_bin, tmp_path, writer):
    d, before, proc, _temp, target = caught_mid_write(airmass_bin, writer, tmp_path)
    # SIGINT to the main thread, which does the writing and the commit: it runs the handler
    # before its next instruction once continued. Sent to the process, the signal may go to a
    # worker thread that is scheduled after the main thread has already committed (seen once:
    # "a.vdb replaced after Ctrl-C", with "cancelled" from the next output's check).
    interrupt_main_thread(proc.pid)
    proc.send_signal(signal.SIGCONT)
    _, err = proc.communicate(timeout=120)
    assert temporaries(d) == [], err
    if writer in HONOURS_CANCEL_WHILE_WRITING:
        assert proc.returncode != 0 and "cancel" in err, (proc.returncode, err)
        assert (d / target).read_bytes() == before[target], f"{target} replaced after Ctrl-C"
    elif proc.returncode != 0:
        assert "cancel" in err, err
    assert_previous_or_complete(d, before, changed_ok=True)


@pytest.mark.parametrize("writer", WRITERS)
def test_kill_9_while_writing_leaves_a_named_temporary_the_next_run_removes(airmass_bin, tmp_path, writer):
    d, before, proc, temp, target = caught_mid_write(airmass_bin, writer, tmp_path)
    # A temporary of a live process (this one) for the same destination: never touched. For
    # compare, the staging folder of a live process for the same DIR.
    folder, name = os.path.split(target)
    stem, ext = os.path.splitext(name)
    if folder:
        live = f".{folder}.airmass-stage-{os.getpid()}"
        (d / live).mkdir()
        (d / live / "job.json").write_bytes(b"in use")
    else:
        live = f".{stem}.airmass-tmp-{os.getpid()}-0{ext}"
        (d / live).write_bytes(b"in use")
    proc.send_signal(signal.SIGKILL)
    proc.communicate(timeout=60)  # reaped: its pid no longer exists
    assert (d / target).read_bytes() == before[target]
    assert_previous_or_complete(d, before, changed_ok=True)
    left = [t for t in temporaries(d) if t != live]
    assert temp in left or temp.split(os.sep)[0] in left, (temp, left)
    for t in left:
        assert destination_of(t)[1] == proc.pid, left
    # The next run of the same command cleans up after the killed one (not after the live one).
    p = run(airmass_bin, WRITERS[writer](d, 0))
    assert temporaries(d) == [live], p.stderr
    assert set(snapshot(d)) == set(before)


# ---- stdout writers -----------------------------------------------------------------------------
@pytest.mark.parametrize("args,stdin", [
    (["sun", "--latitude", "48", "--longitude", "11", "--time", "2026-06-21T12:00:00Z"], None),
    (["eval", "--preset", "earth"], "0,30,40,0\n"),
    (["chapman"], "100,45\n"),
])
def test_stdout_on_a_full_disk_is_an_error(airmass_bin, args, stdin):
    with open("/dev/full", "w") as full:
        p = subprocess.run([str(airmass_bin), *args], input=stdin, stdout=full, stderr=subprocess.PIPE, text=True,
                           timeout=60)
    assert p.returncode != 0, p.stderr
    assert "cannot write the output" in p.stderr, p.stderr
