"""The library's contact sheet (:mod:`svbrdf.runtime.outputs.contact_sheet`): the "view" link of each material with a
viewer page, relative so that ``index.html`` works from disk (checked in headless Chromium too)."""

import time
from html.parser import HTMLParser
from pathlib import Path
from urllib.parse import unquote, urljoin, urlparse

import numpy as np
import pytest

from svbrdf.runtime.outputs.contact_sheet import render_html, write_contact_sheet
from svbrdf.runtime.core.maps import Maps, normalize_normals
from svbrdf.runtime.outputs.texture_set import write_texture_set
from svbrdf.runtime.outputs.viewer import VIEWER_FILE, write_viewer

#: A name that needs quoting in a URL (space and '#').
ODD = "oak #2"


class _Links(HTMLParser):
    def __init__(self):
        super().__init__()
        self.links = []  # (class, href, text)
        self._open = None

    def handle_starttag(self, tag, attrs):
        if tag == "a":
            a = dict(attrs)
            self._open = [a.get("class"), a.get("href"), ""]

    def handle_data(self, data):
        if self._open is not None:
            self._open[2] += data

    def handle_endtag(self, tag):
        if tag == "a" and self._open is not None:
            self.links.append(tuple(self._open))
            self._open = None


def _links(text):
    parser = _Links()
    parser.feed(text)
    return parser.links


def _set(root: Path, name: str) -> Path:
    """A small texture set ``root/name/`` in the project's layout; returns its sidecar."""
    h, w = 16, 24
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
    maps = Maps(diffuse=np.stack([0.2 + 0.6 * xx / w, 0.3 + 0.4 * yy / h, np.full((h, w), 0.5)], -1),
                specular=np.full((h, w, 1), 0.04), roughness=(0.2 + 0.6 * yy / h)[..., None],
                normal=normalize_normals(np.stack([0.3 * np.sin(xx / 3), np.zeros((h, w)), np.ones((h, w))], -1)))
    write_texture_set(maps, root / name, name)
    return root / name / f"{name}.json"


@pytest.fixture
def library(tmp_path):
    """A library folder: ``ODD`` with a viewer page, ``pine`` without, ``bad`` failed (no set)."""
    root = tmp_path / "lib"
    write_viewer(_set(root, ODD))
    _set(root, "pine")
    records = {ODD: {"status": "done", "source": "a/oak #2.png", "scores": {"rerender_rmse": 0.2, "burn_in": 0.1}},
               "pine": {"status": "done", "source": "a/pine.png", "scores": {"rerender_rmse": 0.1, "burn_in": 0.1}},
               "bad": {"status": "failed", "source": "a/bad.png", "error": "a/bad.png: cannot read"}}
    return root, records


def test_a_view_link_where_the_page_exists_relative_to_the_index(library):
    root, records = library
    page = root / ODD / VIEWER_FILE.format(name=ODD)
    views = [(href, text) for cls, href, text in _links(render_html(root, records)) if cls == "view"]
    assert views == [("oak%20%232/oak%20%232_view.html", "view")]  # not for pine (no page) nor bad (no set)
    href = views[0][0]
    assert not urlparse(href).scheme and not href.startswith("/")  # relative: the library can move
    resolved = urlparse(urljoin((root / "index.html").as_uri(), href))
    assert Path(unquote(resolved.path)) == page and page.is_file()

    page.unlink()  # the page gone: no link to it
    assert not [cls for cls, _, _ in _links(render_html(root, records)) if cls == "view"]


@pytest.mark.integration
def test_the_view_link_opens_the_viewer_from_disk(library, browser):
    root, records = library
    index = write_contact_sheet(root, records)["html"]
    browser.open(index.resolve().as_uri())
    assert browser.evaluate("document.querySelectorAll('a.view').length") == 1
    browser.evaluate("setTimeout(() => document.querySelector('a.view').click(), 0) || true")
    want = root / ODD / VIEWER_FILE.format(name=ODD)
    deadline = time.monotonic() + 30
    while True:  # the click navigates away; poll the new page (an evaluate during the navigation may fail)
        try:
            location = urlparse(browser.evaluate("location.href"))
            if Path(unquote(location.path)) == want and browser.evaluate("!!window.svbrdfViewer"):
                break
        except (RuntimeError, OSError):
            pass
        assert time.monotonic() < deadline, "the view link did not open the viewer"
        time.sleep(0.2)
    assert location.scheme == "file"
    assert browser.evaluate("window.svbrdfViewer.ready.then(() => window.svbrdfViewer.size)") == [24, 16]
