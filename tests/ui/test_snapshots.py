"""Layout snapshots (pytest-textual-snapshot): the main screen on the sample
capture at 80×24 on its first error, and the statistics screen. (A 120×40 main
screen snapshot is left out: after other tests in the same process, Textual
splits the blank padding of the hex pane into different background rectangles,
the same picture drawn differently, and the SVG comparison fails.) Update them with
``pytest tests/ui --snapshot-update`` after a deliberate change, and look at
the SVGs before committing."""

import os

import analyzer
from analyzer.tui.run import make_app, stop_feed
from tests.conftest import ROOT

SAMPLE = os.path.join("captures", "demo-socat.log")


def sample_app():
    os.chdir(ROOT)   # the status bar shows the path as given: keep it relative
    return make_app(analyzer.open(SAMPLE), mode="view")


async def loaded(pilot):
    model = pilot.app.model
    # loaded whole, and the wiring doctor's word in: it comes from a process of its
    # own, and its count of findings is on the status bar
    while not (model.done and (model.findings_known or model.doctor_error)):
        await pilot.pause(0.05)
    await pilot.press("home")     # the same selection however the batches arrived
    await pilot.pause(0.3)


def snapshot_after(snap_compare, size: tuple[int, int], *keys: str) -> bool:
    """The sample loaded, ``keys`` pressed, compared with the stored snapshot."""
    app = sample_app()

    async def run_before(pilot):
        await loaded(pilot)
        await pilot.press(*keys)
        await pilot.pause(0.2)

    try:
        return snap_compare(app, terminal_size=size, run_before=run_before)
    finally:
        stop_feed(app)


def test_main_screen_80x24_on_first_error(snap_compare):
    assert snapshot_after(snap_compare, (80, 24), "e")


def test_statistics_screen(snap_compare):
    assert snapshot_after(snap_compare, (120, 40), "S")
