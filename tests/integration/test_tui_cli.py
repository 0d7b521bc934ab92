"""The TUI's command-line side: view needs a terminal, bad keymaps and filters
are one line, and live/demo/replay print (not open the TUI) when piped."""

from tests.conftest import SOCAT_LOG, run_cli


def test_view_without_a_terminal_is_one_line():
    r = run_cli("view", "captures/demo-socat.log")
    assert r.returncode == 2 and r.stderr.strip() == \
        "gimbalscope: error: view needs a terminal (for scripts: gimbalscope decode)"


def test_view_prepares_its_decoding_process_first_and_ends_it_when_unused(monkeypatch, capsys):
    """``view`` starts the interpreter of its decoding process before its own
    modules are imported (the first screen comes sooner); a view that stops
    before it decodes (here: no terminal) leaves nothing running."""
    from analyzer import worker_process
    from analyzer.cli.main import main

    spawned = []
    real = worker_process.subprocess.Popen

    def popen(*args, **kw):
        spawned.append(real(*args, **kw))
        return spawned[-1]
    monkeypatch.setattr(worker_process.subprocess, "Popen", popen)
    assert main(["view", SOCAT_LOG]) == 2
    assert "view needs a terminal" in capsys.readouterr().err
    assert len(spawned) == 1 and spawned[0].poll() is not None
    assert main(["decode", SOCAT_LOG, "--format", "jsonl"]) == 0
    assert len(spawned) == 1   # only view prepares one


def test_bad_keymap_is_one_line(tmp_path):
    from analyzer.tui.run import KeymapError, load_keymap

    good = tmp_path / "good.toml"
    good.write_text('app.filter = "ctrl+l"\n"app.next_error" = "x"\n')   # a dotted key, a quoted one
    assert load_keymap(str(good)) == {"app.filter": "ctrl+l", "app.next_error": "x"}
    bad = tmp_path / "keys.toml"
    bad.write_text("app.filter = [1]\n")
    try:
        load_keymap(str(bad))
    except KeymapError as e:
        assert "must be key strings" in str(e)
    else:
        raise AssertionError("a keymap with a list value was accepted")
    missing = tmp_path / "none.toml"
    try:
        load_keymap(str(missing))
    except KeymapError as e:
        assert str(missing) in str(e) and "cannot read" in str(e)
    else:
        raise AssertionError("a missing keymap was accepted")


def test_replay_piped_prints_events(tmp_path):
    out = tmp_path / "c.mcap"
    assert run_cli("convert", "captures/demo-socat.log", "-o", out).returncode == 0
    r = run_cli("replay", out, "--speed", "max")
    assert r.returncode == 0 and len(r.stdout.splitlines()) == 474


def test_a_damaged_mcap_is_one_line_not_noise(tmp_path):
    bad = tmp_path / "cut.mcap"
    bad.write_bytes(bytes(range(256)) * 8)
    for cmd in ("decode", "stats", "doctor"):
        r = run_cli(cmd, bad)
        assert r.returncode == 2 and r.stderr.strip() == \
            f"gimbalscope: error: {bad}: not an MCAP file (it does not start with the MCAP magic bytes)"
