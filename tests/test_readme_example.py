"""The README's example runs as written and prints what its comments say (the README's numbers are
produced by the code next to them, issue 19). The first ```python block of README.md is executed in a
temporary directory; each ``print(...)  # expected`` line must print exactly ``expected``."""
import contextlib
import io
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
README = ROOT / "README.md"


def readme_example():
    match = re.search(r"```python\n(.*?)```", README.read_text(), re.S)
    assert match, "README.md has no ```python block"
    return match.group(1)


def expected_prints(code):
    """The comment after each print(...) line, in order."""
    return [line.split("#", 1)[1].strip() for line in code.splitlines()
            if line.startswith("print(") and "#" in line]


def test_the_example_states_what_it_prints():
    assert expected_prints(readme_example()), "the README example should show what it prints"


def test_the_readme_example_runs_and_prints_what_it_says(tmp_path, monkeypatch):
    pytest.importorskip("matplotlib")
    import matplotlib
    matplotlib.use("Agg")
    code = readme_example()
    monkeypatch.chdir(tmp_path)
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        exec(compile(code, str(README), "exec"), {"__name__": "readme_example"})
    assert out.getvalue().splitlines() == expected_prints(code)
    assert any(p.suffix == ".png" and p.stat().st_size > 0 for p in tmp_path.iterdir()), "the example's figure"
    import matplotlib.pyplot as plt
    plt.close("all")
