"""Screenshot of reports/explorer.html (headless Chromium, offline, one axis brushed) -> reports/explorer.png.

Run after `dvc repro` from the repository root: `python ci/explorer_screenshot.py`. Uses the browser test's
Chromium settings (tests/browser.py)."""

from __future__ import annotations

import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "tests"))

from browser import chromium, wait_for  # noqa: E402


def main(page: Path = REPO / "reports/explorer.html", out: Path = REPO / "reports/explorer.png") -> None:
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.by import By

    driver = chromium(1400, 1500)
    try:
        driver.get(page.resolve().as_uri())
        wait_for(driver, "window.hevExplorer && window.hevExplorer.ready")
        axis = driver.find_elements(By.CSS_SELECTOR, ".parcoords .axis-brush .background")[8]  # fc
        h = axis.rect["height"]
        ActionChains(driver).move_to_element_with_offset(axis, 0, 0.05 * h).click_and_hold().move_by_offset(
            0, 0.4 * h
        ).release().perform()
        wait_for(driver, "document.getElementById('parcoords').data[0].dimensions[8].constraintrange")
        driver.save_screenshot(str(out))
        print(f"wrote {out} ({driver.find_element(By.ID, 'count').text})")
    finally:
        driver.quit()


if __name__ == "__main__":
    main()
