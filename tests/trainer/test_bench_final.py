"""svbrdf.trainer.bench.final: the argument checks and the report (the timed runs themselves take minutes)."""

from svbrdf.trainer.bench import final


def test_bad_arguments_are_one_line_errors(tmp_path, capsys):
    assert final.main(["--modes", "turbo", "--out", str(tmp_path)]) == 2
    assert capsys.readouterr().err.strip().count("\n") == 0
    assert final.main(["--size", "8", "--out", str(tmp_path)]) == 2
    (tmp_path / "results.md").write_text("kept")
    assert final.main(["--out", str(tmp_path)]) == 2
    assert "use --force" in capsys.readouterr().err
    assert (tmp_path / "results.md").read_text() == "kept"


def test_markdown_reports_medians_and_what_each_run_did():
    doc = {"command": "python -m svbrdf.trainer.bench.final", "date": "2026-01-01", "threads": 2, "size": 1024,
           "rows": [{"case": "a", "mode": "auto", "seconds": 50.0, "refine": {"skipped": True}},
                    {"case": "a", "mode": "fixed", "seconds": 150.0, "refine": {"iterations": 600}},
                    {"case": "b", "mode": "auto", "seconds": 90.0,
                     "refine": {"iterations": 250, "stopped_early": True}}],
           "summary": {"auto": {"median_seconds": 70.0, "min_seconds": 50.0, "max_seconds": 90.0, "photos": 2}}}
    md = final.markdown(doc)
    assert "| auto | 2 | 70.0 | 50.0 | 90.0 |" in md
    assert "skipped (preview explains the photo)" in md and "250 it, stopped early" in md and "600 it" in md
