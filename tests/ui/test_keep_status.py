"""`live --keep` in the TUI: the status line says how many windows were kept, how
many events matched and how much was dropped, as the tap goes."""

from __future__ import annotations

import os

from analyzer.analysis.filter import compile_filter
from analyzer.capture import open_live
from analyzer.info import CaptureInfo
from analyzer.tui.run import make_app, stop_feed
from analyzer.writers.windows import WindowKeeper
from tests.conftest import frame
from tests.ui.test_pilot import SIZE, exchange, pty_pair, run, settle
from tests.ui.test_status_bar import wire_line

NAK = b"\x15"


def test_the_status_line_counts_windows_matches_and_drops(tmp_path):
    ma, _sa, pa = pty_pair()
    mb, _sb, pb = pty_pair()
    capture = open_live([pa, pb])
    info = CaptureInfo.of(capture, command="live")
    keeper = WindowKeeper(str(tmp_path), info, compile_filter('status == "nak"'), 'status == "nak"',
                          before=0.05, after=0.05)
    app = make_app(capture, mode="live", ports=[pa, pb], info=info, listeners=[keeper], windows=keeper)

    async def drive():
        async with app.run_test(size=SIZE) as pilot:
            exchange(ma, mb)   # a command and its ACK: no match
            await settle(pilot, app, lambda a: a.model.row_count >= 2)
            assert "KEEP 0 windows, 0 matched" in wire_line(app)
            os.write(ma, frame((1, 1, 1), 0, "HO"))
            os.write(mb, NAK)
            await settle(pilot, app, lambda a: "1 window, 1 matched" in wire_line(app),
                         what=lambda a: wire_line(a))
        stop_feed(app)

    run(drive())
    assert [p.name for p in tmp_path.glob("window-*.mcap")] == ["window-0001.mcap"]
