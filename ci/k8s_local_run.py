#!/usr/bin/env python3
"""Run the Kubernetes render farm of deploy/k8s on this machine, as a stand-in for a cluster.

ci/k8s-check.sh runs it after validating the manifests against the Kubernetes schemas. The schemas say
whether a cluster would accept the manifests; this says whether the farm they describe renders the right
image. It

1. checks what the schemas cannot: the render Job is an Indexed Job whose `completions` equals the N of
   every `--part env/N` in its command, both Jobs mount the same ReadWriteMany claim (pvc.yaml) at the
   same path, the parts land where the merge reads them;
2. runs the render Job's container command once per index 0..completions-1, as the Job's pods would
   (JOB_COMPLETION_INDEX set), then once more for index 0 (a retried pod: its checkpoint exists, so the
   command resumes it) and once for index N (must be refused with the exit code that the Job's
   podFailurePolicy turns into FailIndex);
3. runs the merge Job's command, then one plain `vkpath render` of the same scene and flags, and requires
   the merged images to hold the single render's pixels bit for bit (`vkpath compare`).

What stands in for the cluster: the image's `vkpath` is $VKPATH (default target/debug/vkpath), found
through PATH (a directory holding a `vkpath` symlink comes first), so the command runs as written; the
volume's mount path (/farm) is a temporary directory, by rewriting that path prefix in the command strings
(a container would see the volume at /farm, but this machine has no /farm to write). The render gets the
extra flags of --flags (default `--width 64 --height 48 --spp 16`, from $VKPATH_K8S_FLAGS when set) after
the manifest's own `args:`, which the command passes to vkpath through "$@", so the check takes seconds.

Not covered: scheduling, images, the volume driver, retries and signals as Kubernetes does them (no
cluster here). Python 3.11 standard library and PyYAML (which kubernetes-validate installs).

Exit status: 0 when every check passed, 1 when one failed, 2 on bad arguments or unreadable manifests.
"""

from __future__ import annotations

import argparse
import os
import re
import shlex
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import yaml

REPO = Path(__file__).resolve().parent.parent
DEFAULT_FLAGS = "--width 64 --height 48 --spp 16"
# One vkpath run at the test size takes seconds on lavapipe; this only stops a hung run from hanging CI.
RUN_TIMEOUT_S = 120


class Failed(Exception):
    """A check failed; the message says which and why."""


class Report:
    def __init__(self) -> None:
        self.passed = 0
        self.failed = 0

    def ok(self, what: str) -> None:
        self.passed += 1
        print(f"  ok: {what}")

    def fail(self, what: str) -> None:
        self.failed += 1
        print(f"  FAIL: {what}")

    def check(self, cond: bool, what: str, why: str = "") -> bool:
        if cond:
            self.ok(what)
        else:
            self.fail(f"{what}{': ' + why if why else ''}")
        return cond


def load_one(path: Path) -> dict:
    """The single object of a manifest (these files hold one each)."""
    try:
        docs = [d for d in yaml.safe_load_all(path.read_text()) if d is not None]
    except (OSError, yaml.YAMLError) as e:
        print(f"k8s_local_run: cannot read {path}: {e}", file=sys.stderr)
        raise SystemExit(2)
    if len(docs) != 1 or not isinstance(docs[0], dict):
        print(f"k8s_local_run: {path} should hold exactly one Kubernetes object", file=sys.stderr)
        raise SystemExit(2)
    return docs[0]


def dig(obj, *keys, default=None):
    for k in keys:
        if isinstance(obj, dict) and k in obj:
            obj = obj[k]
        elif isinstance(obj, list) and isinstance(k, int) and 0 <= k < len(obj):
            obj = obj[k]
        else:
            return default
    return obj


def only_container(job: dict, name: str) -> dict:
    containers = dig(job, "spec", "template", "spec", "containers", default=[])
    if len(containers) != 1:
        raise Failed(f"{name}: expected one container, found {len(containers)} (this stand-in runs one)")
    return containers[0]


def claim_mount(job: dict, container: dict, name: str) -> tuple[str, str]:
    """(claimName, mountPath) of the container's PersistentVolumeClaim volume."""
    volumes = {v.get("name"): v for v in dig(job, "spec", "template", "spec", "volumes", default=[])}
    found = []
    for m in container.get("volumeMounts", []):
        claim = dig(volumes.get(m.get("name")), "persistentVolumeClaim", "claimName")
        if claim:
            found.append((claim, m.get("mountPath", "")))
    if len(found) != 1:
        raise Failed(f"{name}: expected one mounted PersistentVolumeClaim, found {len(found)}")
    return found[0]


class Farm:
    """What the manifests say, checked for consistency (step 1)."""

    def __init__(self, render: dict, merge: dict, pvc: dict, report: Report) -> None:
        r = report
        spec = render.get("spec", {})
        pod = dig(spec, "template", "spec", default={})
        r.check(
            render.get("apiVersion") == "batch/v1" and render.get("kind") == "Job",
            "render-job.yaml is a batch/v1 Job",
            f"found {render.get('apiVersion')} {render.get('kind')}",
        )
        r.check(
            spec.get("completionMode") == "Indexed",
            "render Job has completionMode: Indexed (each pod gets JOB_COMPLETION_INDEX)",
            f"found {spec.get('completionMode')!r}; without it no pod is told which part it renders",
        )
        n = spec.get("completions")
        if not isinstance(n, int) or n < 1:
            raise Failed(f"render Job: completions must be a positive integer, found {n!r}")
        self.n = n
        # backoffLimitPerIndex and podFailurePolicy are refused by the API server with another policy.
        needs_never = "backoffLimitPerIndex" in spec or "podFailurePolicy" in spec
        allowed = ("Never",) if needs_never else ("Never", "OnFailure")
        r.check(
            pod.get("restartPolicy") in allowed,
            f"render pods have restartPolicy {pod.get('restartPolicy')}",
            f"must be {' or '.join(allowed)}",
        )

        c = only_container(render, "render Job")
        self.image = c.get("image")
        command = c.get("command") or []
        if len(command) < 3 or command[:2] != ["sh", "-c"]:
            raise Failed("render Job: the command should be [sh, -c, SCRIPT, ...] so the shell expands "
                         f"JOB_COMPLETION_INDEX; found {command[:2]}")
        self.script = command[2]
        self.render_args = c.get("args") or []
        self.render_argv = command + self.render_args
        if '"$@"' in self.script:
            # sh -c SCRIPT A B...: A is $0 and only B... reach "$@"; without an A the first flag is lost.
            r.check(len(command) >= 4, 'render command names $0 after the script, so args reach "$@"',
                    "add a name after the script, e.g. vkpath-render")
        else:
            raise Failed('render Job: the script does not pass "$@" to vkpath, so the flags in args: '
                         "(and this check's small test size) would not reach it")
        # Kubernetes rewrites these in a command before the shell sees it ($(NAME) of a container env var
        # becomes its value, $$ becomes $), and this stand-in runs the command as written: keep them out.
        rewritten = re.findall(r"\$\$|\$\(", "".join(command[2:] + self.render_args))
        r.check(not rewritten, "render command has no $(...) or $$, which Kubernetes would rewrite",
                f"found {sorted(set(rewritten))}: the pod would run another command than this check")
        parts = re.findall(r"--part[ =](\S+)", self.script)
        r.check(bool(parts), "render command uses --part", "no --part in the script")
        bad = [p for p in parts if p != f"env/{n}"]
        r.check(
            bool(parts) and not bad,
            f"completions ({n}) equals the N of every --part env/N in the command ({len(parts)} uses)",
            f"found --part {', '.join(bad)}: fewer completions than N leave parts unrendered (the merge "
            "refuses), more run indexes that vkpath refuses",
        )
        scenes = set(re.findall(r"vkpath\s+render\s+(\S+)", self.script))
        if len(scenes) != 1:
            raise Failed(f"render Job: expected one scene path after `vkpath render`, found {sorted(scenes)}")
        self.scene = scenes.pop()
        self.claim, self.mount = claim_mount(render, c, "render Job")
        r.check(
            self.scene.startswith(self.mount + "/") and f"{self.mount}/" in self.script,
            f"render reads the scene and writes its checkpoint under the volume's mount path {self.mount}",
            f"scene {self.scene}",
        )
        self.env = c.get("env") or []

        r.check(
            pvc.get("kind") == "PersistentVolumeClaim" and dig(pvc, "metadata", "name") == self.claim,
            f"pvc.yaml defines the claim the render Job mounts ({self.claim})",
            f"pvc.yaml is {pvc.get('kind')} {dig(pvc, 'metadata', 'name')!r}",
        )
        modes = dig(pvc, "spec", "accessModes", default=[])
        r.check(
            "ReadWriteMany" in modes,
            "the claim is ReadWriteMany (pods on many nodes write parts at once)",
            f"accessModes {modes}",
        )

        r.check(
            merge.get("apiVersion") == "batch/v1" and merge.get("kind") == "Job",
            "merge-job.yaml is a batch/v1 Job",
            f"found {merge.get('apiVersion')} {merge.get('kind')}",
        )
        mc = only_container(merge, "merge Job")
        r.check(mc.get("image") == self.image, f"both Jobs run the same image ({self.image})",
                f"merge runs {mc.get('image')}")
        mclaim, mmount = claim_mount(merge, mc, "merge Job")
        r.check(
            (mclaim, mmount) == (self.claim, self.mount),
            f"merge Job mounts the same claim at the same path ({mclaim} at {mmount})",
            f"render: {self.claim} at {self.mount}",
        )
        self.merge_argv = (mc.get("command") or []) + (mc.get("args") or [])
        argv = self.merge_argv
        if len(argv) < 3 or argv[:2] != ["vkpath", "merge"]:
            raise Failed(f"merge Job: expected the command `vkpath merge DIR -o ...`, found {argv}")
        self.parts_dir = argv[2]
        outs = [argv[i + 1] for i, a in enumerate(argv[:-1]) if a in ("-o", "--output")]
        self.merged = {Path(o).suffix: o for o in outs}
        r.check(".exr" in self.merged, "merge writes an EXR (compared with the single render)",
                f"outputs {outs}")
        r.check(
            self.parts_dir.startswith(self.mount + "/") and self.parts_dir + "/" in self.script,
            f"merge reads the parts directory the render writes its checkpoints to ({self.parts_dir})",
            "the render script does not mention it",
        )
        self.fail_index_codes = sorted(
            code
            for rule in dig(spec, "podFailurePolicy", "rules", default=[])
            if rule.get("action") == "FailIndex" and dig(rule, "onExitCodes", "operator") == "In"
            for code in dig(rule, "onExitCodes", "values", default=[])
        )


class Runner:
    """Runs the manifests' commands with /farm mapped to a temporary directory (steps 2 and 3)."""

    def __init__(self, farm: Farm, tmp: Path, vkpath: Path, scene: Path, flags: list[str],
                 report: Report) -> None:
        self.farm, self.tmp, self.vkpath, self.flags, self.r = farm, tmp, vkpath, flags, report
        self.scene_src = scene
        self.root = tmp / "farm"
        self.work = tmp / "work"  # the commands' working directory: empty, like a container's
        bindir = tmp / "bin"
        for d in (self.root, self.work, bindir):
            d.mkdir()
        # The image's vkpath, found through PATH as in the container: the command is run as written.
        (bindir / "vkpath").symlink_to(vkpath)
        env = dict(os.environ)
        env["PATH"] = f"{bindir}{os.pathsep}{env.get('PATH', '')}"
        # `--part env/N` also reads Slurm's index; a CI job inside a Slurm array must not change the part.
        for var in ("SLURM_ARRAY_TASK_ID", "JOB_COMPLETION_INDEX"):
            env.pop(var, None)
        for e in farm.env:
            if "value" in e:
                env[e["name"]] = self.map(str(e["value"]))
            else:
                # e.g. LP_NUM_THREADS from the pod's CPU request: there is no pod here.
                print(f"  note: env {e['name']} comes from the cluster (valueFrom); not set here")
        self.env = env

    def map(self, s: str) -> str:
        """The string with the volume's mount path (e.g. /farm) as a path prefix replaced by the temporary
        directory. Only whole path components: /farm and /farm/x, not /farmhouse."""
        mount = re.escape(self.farm.mount)
        return re.sub(rf"(?<![\w./-]){mount}(?=/|$|[^\w.-])", str(self.root), s)

    def run(self, what: str, argv: list[str], index: int | None = None) -> subprocess.CompletedProcess:
        env = dict(self.env)
        if index is not None:
            env["JOB_COMPLETION_INDEX"] = str(index)
        shown = " ".join("'<script>'" if "\n" in a else shlex.quote(a) for a in argv)
        prefix = f"JOB_COMPLETION_INDEX={index} " if index is not None else ""
        print(f"  run ({what}): {prefix}{shown}")
        try:
            return subprocess.run(argv, env=env, cwd=self.work, capture_output=True, text=True,
                                  timeout=RUN_TIMEOUT_S)
        except subprocess.TimeoutExpired:
            raise Failed(f"{what}: still running after {RUN_TIMEOUT_S} s")

    def require(self, what: str, p: subprocess.CompletedProcess, rc: int | list[int] = 0) -> None:
        want = rc if isinstance(rc, list) else [rc]
        if p.returncode in want:
            self.r.ok(f"{what} exited {p.returncode}")
            return
        tail = "\n".join((p.stdout + p.stderr).strip().splitlines()[-30:])
        raise Failed(f"{what} exited {p.returncode}, expected {' or '.join(map(str, want))}; its output:\n"
                     f"{tail}")

    def parts(self) -> set[Path]:
        d = Path(self.map(self.farm.parts_dir))
        return set(d.glob("*.ckpt")) if d.is_dir() else set()

    def go(self) -> None:
        f, r = self.farm, self.r
        scene = Path(self.map(f.scene))
        scene.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(self.scene_src, scene)
        print(f"  the volume {f.mount} is {self.root}; scene {self.scene_src.name} copied to {scene}")
        render_argv = [self.map(a) for a in f.render_argv] + self.flags

        # Step 2: the Job's pods, one per index.
        for i in range(f.n):
            before = self.parts()
            p = self.run(f"render pod, index {i}", render_argv, index=i)
            self.require(f"render pod {i}", p)
            new = self.parts() - before
            if len(new) != 1:
                raise Failed(f"render pod {i} should have written one checkpoint in {f.parts_dir}, "
                             f"wrote {sorted(x.name for x in new)}")
            r.ok(f"render pod {i} wrote {f.parts_dir}/{new.pop().name}")

        # A retried pod: its checkpoint exists, so the command takes its --resume branch; resuming a
        # finished part must succeed and leave the same set of parts.
        before = self.parts()
        p = self.run("retried render pod, index 0", render_argv, index=0)
        self.require("retried render pod 0 (resumes its checkpoint)", p)
        r.check(self.parts() == before, "the retry left the same parts", f"now {sorted(self.parts())}")

        # An index beyond N (completions larger than the N of --part env/N) must fail, with the exit code
        # that the Job's podFailurePolicy turns into FailIndex (no pointless retries), writing nothing.
        codes = f.fail_index_codes or [c for c in range(1, 256)]
        p = self.run(f"render pod, index {f.n} (one too many)", render_argv, index=f.n)
        self.require(f"render pod {f.n} (beyond --part env/{f.n}, refused)", p, codes)
        r.check(self.parts() == before, f"the refused index {f.n} wrote no part",
                f"now {sorted(x.name for x in self.parts())}")

        # Step 3: the merge Job, then one plain render to compare with.
        p = self.run("merge pod", [self.map(a) for a in f.merge_argv])
        self.require("merge pod", p)
        single = {ext: self.tmp / f"single{ext}" for ext in f.merged}
        argv = [str(self.vkpath), "render", str(scene)]
        for out in single.values():
            argv += ["-o", str(out)]
        # The manifest's own args (if any) and the test flags: the same render as the parts'.
        argv += ["--quiet"] + [self.map(a) for a in f.render_args] + self.flags
        p = self.run("single render", argv)
        self.require("single render", p)
        for ext, out in sorted(f.merged.items()):
            merged = Path(self.map(out))
            # The pixels, not the files: their metadata differ (the single render records its seconds).
            c = subprocess.run(
                [str(self.vkpath), "compare", str(merged), str(single[ext])],
                capture_output=True,
                text=True,
            )
            r.check(
                c.returncode == 0,
                f"merged {out} has the single render's {ext.lstrip('.').upper()} pixels bit for bit "
                f"(vkpath compare)",
                (c.stdout + c.stderr).strip(),
            )


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    k8s = REPO / "deploy" / "k8s"
    ap.add_argument("--render-job", type=Path, default=k8s / "render-job.yaml")
    ap.add_argument("--merge-job", type=Path, default=k8s / "merge-job.yaml")
    ap.add_argument("--pvc", type=Path, default=k8s / "pvc.yaml")
    ap.add_argument("--scene", type=Path, default=REPO / "scenes" / "course.toml",
                    help="copied onto the stand-in volume as the scene the render Job names")
    ap.add_argument("--vkpath", type=Path,
                    default=Path(os.environ.get("VKPATH", REPO / "target" / "debug" / "vkpath")),
                    help="the binary standing in for the image's vkpath (default $VKPATH, else "
                         "target/debug/vkpath)")
    ap.add_argument("--flags", default=os.environ.get("VKPATH_K8S_FLAGS", DEFAULT_FLAGS),
                    help="extra vkpath render flags, appended to the render command (default: %(default)s)")
    ap.add_argument("--check-only", action="store_true",
                    help="check the manifests' consistency; run nothing")
    ap.add_argument("--keep", action="store_true", help="keep the temporary directory")
    a = ap.parse_args()

    report = Report()
    print(f"k8s local run: {a.render_job.name}, {a.merge_job.name}, {a.pvc.name}")
    try:
        farm = Farm(load_one(a.render_job), load_one(a.merge_job), load_one(a.pvc), report)
    except Failed as e:
        report.fail(str(e))
    if report.failed or a.check_only:
        print(f"k8s local run: {report.passed} passed, {report.failed} failed")
        return 1 if report.failed else 0

    vkpath = a.vkpath if a.vkpath.is_absolute() else Path.cwd() / a.vkpath
    if not (vkpath.is_file() and os.access(vkpath, os.X_OK)):
        print(f"k8s_local_run: no vkpath binary at {a.vkpath}: build it (cargo build) or set VKPATH",
              file=sys.stderr)
        return 2
    if not a.scene.is_file():
        print(f"k8s_local_run: no scene file {a.scene}", file=sys.stderr)
        return 2
    tmp = Path(tempfile.mkdtemp(prefix="vkpath-k8s-")).resolve()
    # The directory is pasted into a shell script in place of /farm: it must need no quoting there.
    if not re.fullmatch(r"[A-Za-z0-9_./-]+", str(tmp)):
        print(f"k8s_local_run: the temporary directory {tmp} has characters the shell would split or "
              "expand; set TMPDIR to a plainer path", file=sys.stderr)
        return 2
    runner = Runner(farm, tmp, vkpath, a.scene, shlex.split(a.flags), report)
    try:
        runner.go()
    except Failed as e:
        report.fail(str(e))
    if report.failed or a.keep:
        print(f"  files kept in {tmp}")
    else:
        shutil.rmtree(tmp)
    print(f"k8s local run: {report.passed} passed, {report.failed} failed")
    return 1 if report.failed else 0


if __name__ == "__main__":
    sys.exit(main())
