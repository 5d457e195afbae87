"""A headless Chromium for the browser tests (Debian's chromium and chromium-driver, installed by .ci/run),
with the network shut: every request that is not a file goes to a closed proxy port."""

from __future__ import annotations

import os
import shutil
import time

import pytest

CHROMIUM = shutil.which("chromium") or "/usr/bin/chromium"
CHROMEDRIVER = shutil.which("chromedriver") or "/usr/bin/chromedriver"
FLAGS = (
    "--headless=new",
    "--no-sandbox",
    "--disable-gpu",
    "--use-angle=swiftshader",  # WebGL (Plotly's parallel coordinates) in software
    "--enable-unsafe-swiftshader",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--no-first-run",
    "--proxy-server=127.0.0.1:9",  # offline: any network request fails
    "--proxy-bypass-list=<-loopback>",
)


def chromium(width: int = 1400, height: int = 1700):
    """A Selenium-driven headless Chromium; the test is skipped outside CI when none is installed (CI, which
    installs it, fails instead)."""
    if not (os.path.exists(CHROMIUM) and os.path.exists(CHROMEDRIVER)):
        if os.environ.get("CI"):
            pytest.fail("chromium / chromedriver missing: .ci/run installs Debian's chromium and chromium-driver")
        pytest.skip("no chromium / chromedriver on this machine (apt-get install chromium chromium-driver)")
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM
    for flag in (*FLAGS, f"--window-size={width},{height}"):
        options.add_argument(flag)
    return webdriver.Chrome(service=Service(CHROMEDRIVER), options=options)


def wait_for(driver, script: str, timeout_s: float = 30.0):
    """Poll ``return <script>`` until it is truthy; its value."""
    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        value = driver.execute_script(f"return {script}")
        if value:
            return value
        time.sleep(0.1)
    raise TimeoutError(f"page never satisfied: {script}")
