"""Debian's Chromium driven by Selenium for the monitor's tests, and the monitor as a process.

The driver is /usr/bin/chromedriver, given explicitly, so that Selenium Manager never tries to
download one; the browser is /usr/bin/chromium (scripts/setup installs both)."""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from contextlib import contextmanager
from pathlib import Path

import pytest

CHROMIUM, CHROMEDRIVER = "/usr/bin/chromium", "/usr/bin/chromedriver"
ROOT = Path(__file__).resolve().parents[3]
FLAGS = ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         "--disable-default-apps", "--no-first-run", "--disable-extensions",
         "--window-size=1280,1500")


def have_browser() -> bool:
    return os.access(CHROMIUM, os.X_OK) and os.access(CHROMEDRIVER, os.X_OK)


@contextmanager
def chromium():
    if not have_browser():
        pytest.fail("Debian's chromium and chromium-driver are needed (./scripts/setup installs them)")
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service
    opts = webdriver.ChromeOptions()
    for flag in FLAGS:
        opts.add_argument(flag)
    opts.binary_location = CHROMIUM
    driver = webdriver.Chrome(service=Service(CHROMEDRIVER), options=opts)
    try:
        yield driver
    finally:
        driver.quit()


@contextmanager
def monitor_process(folder, *args):
    """``thermocue monitor FOLDER ARGS`` running; yields (process, URL)."""
    proc = subprocess.Popen([sys.executable, "-m", "experiments", "monitor", str(folder), *args],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=ROOT)
    try:
        url = proc.stdout.readline().strip()
        assert url.startswith("http://"), proc.stderr.read() if proc.poll() is not None else url
        yield proc, url
    finally:
        proc.send_signal(signal.SIGINT)
        try:
            proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()


def wait_for(check, timeout_s=30.0, what="the page"):
    """Poll ``check()`` until it returns something true; fail naming ``what``."""
    end = time.monotonic() + timeout_s
    last = None
    while time.monotonic() < end:
        try:
            last = check()
        except Exception as exc:        # a page still loading: try again
            last = exc
        if last and not isinstance(last, Exception):
            return last
        time.sleep(0.05)
    pytest.fail(f"{what}: not seen in {timeout_s:g} s (last: {last!r})")
