"""experiments._json_main: the shared --out/--quick command line of the JSON experiments."""

import json

from experiments._json_main import json_main


def test_json_main_writes_the_run_and_passes_quick(tmp_path, capsys):
    calls = []

    def run(quick=False):
        calls.append(quick)
        return {"quick": quick, "value": 1.5}

    out = tmp_path / "sub" / "r.json"
    json_main(
        "python -m x",
        "Title line.\nmore",
        "unused.json",
        "help",
        run,
        ["--out", str(out), "--quick"],
    )
    assert calls == [True]
    assert json.loads(out.read_text()) == {"quick": True, "value": 1.5}
    assert f"wrote {out}" in capsys.readouterr().out
