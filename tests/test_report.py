"""`pen report`: every figure kind from the example workspace, HTML and PDF, the CI gate."""

from __future__ import annotations

import json
import re
import shutil
import subprocess
from pathlib import Path

import pytest

from pencli import api
from tests.conftest import REPO, invoke


@pytest.fixture(scope="module")
def example(tmp_path_factory) -> Path:
    """A copy of the bundled example workspace (analysed: stages, two fits, a sweep)."""
    root = tmp_path_factory.mktemp("example")
    shutil.copy(REPO / "examples" / "workspace" / "runs.duckdb", root / "runs.duckdb")
    for folder in ("runs", "fits", "sweeps"):
        shutil.copytree(REPO / "examples" / "workspace" / folder, root / folder)
    return root / "runs.duckdb"


def _images(html: str) -> list[str]:
    """The report's figures: the inline SVG of each <figure>."""
    return re.findall(r"<figure [^>]*>(<svg.*?</svg>)", html, flags=re.S)


def _not_blank(svg: str) -> bool:
    """A figure that draws: paths (data, bars, axes), and text (axis labels, ticks) kept as text."""
    return len(re.findall(r' d="([^"]+)"', svg)) >= 10 and svg.count("<text") >= 6


def test_every_figure_kind_renders_from_the_example_workspace(example, tmp_path, runner):
    kinds = {
        "runs": (["gb-1.0-2", "mc-2.0-4"], 5),  # together: raw, measurements, model vs data per fit (2), energy
        "material": (["--material", "mpacs_c"], 2 + 6),  # intervals + Fig. 16 + model vs data per run
        "sweep": (["--sweep", "1"], 3),  # two heat maps with the boundary, partial dependence (2 variables: no 3-D)
        "diagnosis": (["mc-*", "--diagnose"], 1),
    }
    for name, (args, count) in kinds.items():
        out = tmp_path / f"{name}.html"
        r = invoke(runner, "report", *args, "--out", out, "--db", example)
        assert r.exit_code == 0, r.output
        images = _images(out.read_text())
        assert len(images) >= count, (name, len(images))
        assert all(_not_blank(i) for i in images), name
        pdf = out.with_suffix(".pdf")
        assert pdf.read_bytes().startswith(b"%PDF") and pdf.stat().st_size > 20_000


def test_report_of_a_sampled_sweep_is_binned(workspace, runner):
    """The report of a Latin-hypercube sweep built a grid of every sampled value against every
    other (7.28 TiB at 10⁶ designs; 80 GB here, a MemoryError): a sampled sweep's maps are binned."""
    r = invoke(runner, "sweep", "-p", "appendix_c", "-m", "mpacs_c", "-e", "appendix_c",
               "--vary", "coefficients.strength_factor=0.5:2", "--vary", "coefficients.inertia_coefficient=20:60",
               "--vary", "blade_thickness_mm=1:2", "--sample", "lhs", "--n", "100000", "--json")
    assert r.exit_code == 0, r.output
    out = workspace / "sweep.html"
    r = invoke(runner, "report", "--sweep", "1", "--out", out)
    assert r.exit_code == 0, r.output
    page = out.read_text()
    images = _images(page)
    # three variables: final depth for each of the 3 pairs, energy left and time for the first, the 3-D scatter,
    # the partial dependence; a sample's maps say what each cell averages over
    assert len(images) == 7 and all(_not_blank(i) for i in images)
    captions = re.findall(r"<figcaption>(.*?)</figcaption>", page)
    assert sum("each cell the mean over" in c for c in captions) == 5 and "sampled (100000 designs)" in page


def test_report_of_twelve_runs_draws_them_together_then_gives_each_runs_tables(example, tmp_path):
    """One report of the twelve example runs (how long it takes is measured by bench/bench_report.py): one section
    whose figures hold every run (raw channels, measurements, one model-against-data figure per fit, energy), then
    each run's tables, pointing to its own report for its figures; one run alone is drawn alone."""
    from pencli.report.build import write_report

    sections = api.report_runs(example, ["all"])
    write_report("twelve runs", sections, tmp_path / "all.html")
    assert len(sections) == 13
    together, *each = sections
    fits = {v["material"] for v in api.workspace(example).material_versions()}
    assert [f.paper for f in together.figures] == ["Fig. 11", "Fig. 12", *["Figs. 13–14"] * len(fits), "Fig. 14"]
    assert [row[0] for row in together.tables[0][2]] == [s.title.removeprefix("run ") for s in each]
    assert all(not s.figures and f"pen report {s.title.removeprefix('run ')}" in s.text for s in each)
    html = (tmp_path / "all.html").read_text()
    assert len(_images(html)) == len(together.figures)
    alone = api.report_runs(example, ["mc-1.0-4"])
    assert len(alone) == 1 and [f.paper for f in alone[0].figures] == ["Fig. 11", "Fig. 12", "Fig. 13", "Fig. 14"]


def test_all_writes_one_report_per_run_material_and_sweep_and_an_index(example, tmp_path, runner):
    r = invoke(runner, "report", "--all", "--out", tmp_path / "reports", "--db", example, "--no-pdf")
    assert r.exit_code == 0, r.output
    reports = tmp_path / "reports"
    assert len(list((reports / "runs").glob("*.html"))) == 12
    assert len(list((reports / "materials").glob("*.html"))) == 2
    assert (reports / "sweeps" / "sweep-1.html").is_file()
    links = re.findall(r"<a href='([^']+)'>", (reports / "index.html").read_text())
    written = sorted(p.relative_to(reports).as_posix() for p in reports.rglob("*.html") if p.name != "index.html")
    assert sorted(links) == written  # the index links every report, and nothing else


def test_all_leaves_out_superseded_fits_unless_asked_and_adds_diagnoses_when_asked(example, tmp_path):
    copy = tmp_path / "ws"
    shutil.copytree(Path(example).parent, copy)
    db = copy / "runs.duckdb"
    api.fit(db, "mpacs_c", ["mc-*"], bootstrap=0)  # version 2 supersedes version 1
    titles = [j.title for j in api.report_jobs(db) if j.group == "fitted materials"]
    assert titles == ["material grill_brick v1", "material mpacs_c v2"]
    every = [j.title for j in api.report_jobs(db, all_versions=True) if j.group == "fitted materials"]
    assert sorted(every) == ["material grill_brick v1", "material mpacs_c v1", "material mpacs_c v2"]
    diagnoses = [j for j in api.report_jobs(db, diagnose=True) if j.group == "diagnoses"]
    assert [j.path.as_posix() for j in diagnoses] == ["diagnoses/grill_brick.html", "diagnoses/mpacs_c.html"]


def test_check_gate_names_every_breach_and_exits_1(example, tmp_path, runner):
    ok = invoke(runner, "report", "gb-1.0-2", "--out", tmp_path / "a.html", "--db", example, "--no-pdf",
                "--check", "nrmse<=0.5")
    assert ok.exit_code == 0, ok.output
    strict = invoke(runner, "report", "gb-1.0-2", "mc-1.0-4", "--out", tmp_path / "b.html", "--db", example,
                    "--no-pdf", "--check", "nrmse<=0.0001", "--check", "r2>=0.5")
    assert strict.exit_code == 1
    breaches = [line for line in strict.stderr.splitlines() if line.startswith("check failed")]
    # scoped to what the report is of: its two runs, each in the fit that holds it, not every fitted run
    assert len(breaches) == 2 and all("nrmse" in line for line in breaches), strict.stderr
    assert any("grill_brick v1 run gb-1.0-2" in b for b in breaches) and any("mc-1.0-4" in b for b in breaches)
    page = (tmp_path / "b.html").read_text()  # the report is still published, and records its gate
    assert "checks of this report" in page and page.count("breaks") == 2 and page.count("holds") == 2
    bad = invoke(runner, "report", "gb-1.0-2", "--out", tmp_path / "c.html", "--db", example, "--check", "nrmse<0.1")
    # a malformed gate is a usage error (exit 2), not a breach, and nothing is written
    assert bad.exit_code == 2 and "METRIC<=VALUE" in bad.stderr and not (tmp_path / "c.html").exists()


def test_a_check_that_cannot_be_evaluated_fails_unless_allowed(example, tmp_path, runner):
    """shrink without --diagnose, and fit metrics on a report of a sweep, have nothing to read: the gate says so
    and fails, unless --allow-unchecked; the report records the check as not evaluated."""
    vacuous = invoke(runner, "report", "gb-1.0-2", "--out", tmp_path / "v.html", "--db", example, "--no-pdf",
                     "--check", "shrink>=50")
    assert vacuous.exit_code == 1 and "check not evaluated" in vacuous.stderr and "--diagnose" in vacuous.stderr
    assert "not evaluated" in (tmp_path / "v.html").read_text()
    allowed = invoke(runner, "report", "gb-1.0-2", "--out", tmp_path / "w.html", "--db", example, "--no-pdf",
                     "--check", "shrink>=50", "--allow-unchecked")
    assert allowed.exit_code == 0, allowed.output
    sweep = invoke(runner, "report", "--sweep", "1", "--out", tmp_path / "s.html", "--db", example, "--no-pdf",
                   "--check", "nrmse<=0.5", "--json")
    assert sweep.exit_code == 1
    record = json.loads(sweep.stdout)
    assert record["checks"][0]["evaluated"] is False and "no fitted run" in record["checks"][0]["reason"]


CHROMIUM = shutil.which("chromium-headless-shell") or shutil.which("chromium") or shutil.which("chromium-browser")


@pytest.mark.skipif(CHROMIUM is None, reason="Debian's chromium-headless-shell is not installed (.ci/run installs it)")
def test_html_renders_headless_with_every_image_loaded(example, tmp_path, runner):
    out = tmp_path / "r.html"
    assert invoke(runner, "report", "gb-1.0-2", "--out", out, "--db", example, "--no-pdf").exit_code == 0
    probe = tmp_path / "probe.html"
    probe.write_text(out.read_text().replace("</body>", """<script>
window.addEventListener('load', () => {
  const imgs = Array.from(document.querySelectorAll('figure svg'));
  const ok = imgs.filter(i => i.getBoundingClientRect().width > 200 && i.getBoundingClientRect().height > 100).length;
  document.body.setAttribute('data-images', imgs.length + '/' + ok);
  const caps = Array.from(document.querySelectorAll('figure figcaption')).filter(c => c.textContent.length > 40);
  document.body.setAttribute('data-captions', String(caps.length));
  document.body.setAttribute('data-width', String(document.body.scrollWidth <= window.innerWidth));
});</script></body>"""))
    dom = subprocess.run([CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
                          "--disable-component-update", "--disable-sync", "--no-first-run",
                          f"--user-data-dir={tmp_path / 'profile'}", "--virtual-time-budget=10000", "--dump-dom",
                          probe.as_uri()], capture_output=True, text=True, timeout=120).stdout
    match = re.search(r'data-images="(\d+)/(\d+)"', dom)
    assert match, dom[:500]
    total, loaded = int(match.group(1)), int(match.group(2))
    assert total >= 4 and loaded == total
    # every figure captioned, and nothing wider than the window (images scale down, text wraps)
    assert re.search(r'data-captions="(\d+)"', dom).group(1) == str(total)
    assert 'data-width="true"' in dom


def test_a_workspace_copied_without_its_fits_folder_is_one_line(example, tmp_path, runner):
    """A missing fits/ folder made `pen report` print a FileNotFoundError traceback."""
    import shutil

    copy = tmp_path / "copy"
    shutil.copytree(Path(example).parent / "runs", copy / "runs")
    shutil.copy(example, copy / "runs.duckdb")
    r = invoke(runner, "report", "--material", "mpacs_c", "--out", tmp_path / "m.html", "--db", copy / "runs.duckdb",
               "--no-pdf")
    assert r.exit_code == 1 and "missing from the workspace" in r.stderr and "fits/" in r.stderr, r.output
    assert "Traceback" not in r.output and len(r.stderr.strip().splitlines()) == 1
    assert not (tmp_path / "m.html").exists()
