"""A picture of the web ground station in mid-mission: the formation mission served to a
headless Chromium, with an operator's command in the log and a platform inspected.

The end-to-end tests call :func:`shoot` on a cut-down mission; run this file to remake the
README's picture on the full one::

    .venv/bin/python tests/web/web_screenshot.py docs/img/web-ground-station.png
"""

from __future__ import annotations

import argparse
import hashlib
import time
from pathlib import Path
from typing import Any

from actorswarm.missions import mission
from actorswarm.sim.mission import prepare
from actorswarm.web import Server, SimSource

CHROMIUM = "/usr/bin/chromium"


def formation(platforms: int, *, skip_to: float, until: float) -> SimSource:
    """The formation mission for ``platforms``, run ahead to ``skip_to`` seconds as fast as
    the machine allows, then served slowly (the page is set up at a quarter of real time,
    so a loaded machine does not miss the moment) up to ``until``, where it stops."""
    chosen = mission("formation")
    run = prepare(chosen, platforms=platforms)
    run.advance(skip_to)
    title = (
        chosen.title
        if platforms == chosen.platforms
        else f"formation mission, {platforms} platforms"
    )
    sha = hashlib.sha256(chosen.script_path.read_bytes()).hexdigest()
    return SimSource(run, title=title, sha=sha, speed=0.25, until=until)


def inspect_platform(page: Any, platform: int, *, tries: int = 6) -> None:
    """Click ``platform``'s row of the swarm table until its control blocks are shown. The
    table is redrawn with every swarm message, and a click that lands on a row just
    replaced reaches no listener: on a loaded machine one click is not always enough."""
    from playwright.sync_api import TimeoutError as PageTimeout  # there is a page: installed

    row = f"#swarm-table tbody tr[data-platform='{platform}']"
    for _ in range(tries):
        page.click(row)
        try:
            page.wait_for_selector("#detail-body .acb", timeout=5_000)
            return
        except PageTimeout:
            continue
    raise AssertionError(f"platform {platform}'s control blocks never showed ({tries} clicks)")


def shoot(
    page: Any, url: str, source: SimSource, *, pace: str, path: Path, inspect: int = 3
) -> None:
    """Open ``url``; from the page, back the swarm up, inspect platform ``inspect`` and set
    the pace to ``pace`` (an option of the header's select); once the simulation has
    stopped at its end, save the page to ``path``."""
    page.goto(url)
    page.wait_for_function("document.querySelector('#map').dataset.mode === 'world'")
    page.click("button[data-tab=backup]")
    page.click("#backup-send")
    page.wait_for_selector("#log li[data-op=backup][data-state=done]", timeout=30_000)
    page.click("button[data-tab=event]")
    page.fill("#event-name", "BCtoD_event")
    inspect_platform(page, inspect)
    page.select_option("#speed", pace)
    page.wait_for_selector("#log li[data-op=speed][data-state=done]", timeout=30_000)
    end = time.monotonic() + 120
    while not source.ended():
        assert time.monotonic() < end, f"the simulation did not reach {source.until} s"
        page.wait_for_timeout(200)
    final = source.frame()["t"]
    page.wait_for_function(f"Number(document.querySelector('#map').dataset.t) === {final}")
    page.wait_for_timeout(800)  # the map glides into place
    path.parent.mkdir(parents=True, exist_ok=True)
    page.screenshot(path=str(path))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--platforms", type=int, default=30)
    parser.add_argument("--skip-to", type=float, default=96.0)
    parser.add_argument("--until", type=float, default=121.0)
    parser.add_argument("--pace", default="5")
    args = parser.parse_args()
    from playwright.sync_api import sync_playwright

    source = formation(args.platforms, skip_to=args.skip_to, until=args.until)
    with Server(source) as server, sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=CHROMIUM, args=["--no-sandbox"])
        page = browser.new_page(viewport={"width": 1600, "height": 1000})
        shoot(page, server.url, source, pace=args.pace, path=args.out)
        browser.close()
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
