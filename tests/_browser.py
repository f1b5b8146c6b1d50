"""Headless Chromium for the viewer tests, through Selenium and Debian's chromedriver.

Why WebDriver: it sends real input events (a key on the slider, the mouse over the canvas) and
reads the page back without any protocol code of ours, and Debian builds chromedriver from the
same source as chromium, so the two always match. Selenium is told where the driver is, so it
never tries to download one (Selenium Manager is skipped).

Chromium runs as root here, offline: --no-sandbox, and every feature that would reach the
network turned off, with a fresh profile per session.
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import pytest

CHROMIUM_FLAGS = [
    "--headless=new", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
    "--disable-background-networking", "--disable-component-update", "--disable-sync",
    "--disable-dev-shm-usage", "--force-device-scale-factor=1", "--window-size=1200,850",
]


def chromium_driver(profile: Path):
    """A Selenium Chrome driver on headless Chromium, or pytest.skip saying what is missing."""
    try:
        from selenium import webdriver
        from selenium.webdriver.chrome.service import Service
    except ImportError:
        pytest.skip("selenium is not installed (pip install -e '.[test]')")
    browser = os.environ.get("FUZZYBREP_CHROMIUM") or shutil.which("chromium") or shutil.which("chromium-browser")
    driver = os.environ.get("FUZZYBREP_CHROMEDRIVER") or shutil.which("chromedriver")
    if not browser or not driver:
        missing = " and ".join(n for n, p in (("chromium", browser), ("chromedriver", driver)) if not p)
        pytest.skip(f"{missing} not found (Debian: apt-get install chromium chromium-driver; .ci/run does it)")
    options = webdriver.ChromeOptions()
    options.binary_location = browser
    for flag in CHROMIUM_FLAGS:
        options.add_argument(flag)
    options.add_argument(f"--user-data-dir={profile}")
    return webdriver.Chrome(options=options, service=Service(executable_path=driver))
