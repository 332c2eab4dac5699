"""pycolfrag.analysis.report and pycolfrag.analysis.validation import without matplotlib: a machine
that only analyses results files (tables, the markdown report's numbers) needs no plotting stack.

The check runs in a child interpreter where ``sys.modules['matplotlib'] = None`` makes every
``import matplotlib...`` raise ImportError, as if it were not installed."""
import subprocess
import sys
import textwrap


def test_report_and_validation_import_without_matplotlib():
    code = textwrap.dedent("""
        import sys
        sys.modules["matplotlib"] = None          # any import of matplotlib now raises ImportError
        import pycolfrag.analysis.report, pycolfrag.analysis.validation, pycolfrag.analysis.figures, pycolfrag.results
        from pycolfrag.analysis.data import read_results  # the one reader is reachable too
        loaded = sorted(m for m, v in sys.modules.items() if m.startswith("matplotlib") and v is not None)
        assert not loaded, loaded
        try:
            pycolfrag.analysis.figures.Figure()
        except ImportError:
            print("ok")
    """)
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert p.returncode == 0, p.stderr
    assert p.stdout.strip() == "ok"   # drawing still needs matplotlib, and says so by ImportError
