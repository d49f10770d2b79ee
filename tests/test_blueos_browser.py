"""The extension's page in a real browser (Debian's Chromium, headless, through playwright), served the way
BlueOS ≥ 1.4 serves it: under /extensionv2/wavekeep/ behind a proxy (a real HTTP server on loopback, which
answers 404 to anything outside that prefix). The entry point runs as its container runs it, with no vehicle:
the page says there is no link, refuses to engage with the reason, and a setting saved there persists across a
restart of the extension."""
from __future__ import annotations

import http.server
import shutil
import socket
import threading
import urllib.error
import urllib.request

import pytest
from blueos_rig import Extension

from sitl.harness.ports import free_port

pytestmark = pytest.mark.processes
CHROMIUM = shutil.which("chromium")
FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
         "--disable-component-update", "--disable-sync", "--no-first-run"]
PREFIX = "/extensionv2/wavekeep/"


class Proxy:
    """BlueOS's nginx for one extension: PREFIX + path → the extension's path; anything else is a 404 (counted)."""

    def __init__(self):
        self.target = ""
        self.outside: list[str] = []
        proxy = self

        class Handler(http.server.BaseHTTPRequestHandler):
            def _forward(self) -> None:
                if not self.path.startswith(PREFIX):
                    proxy.outside.append(self.path)
                    self.send_error(404)
                    return
                n = int(self.headers.get("Content-Length") or 0)
                req = urllib.request.Request(proxy.target + self.path[len(PREFIX):], method=self.command,
                                             data=self.rfile.read(n) if n else None,
                                             headers={"Content-Type": self.headers.get("Content-Type", "")})
                try:
                    with urllib.request.urlopen(req, timeout=10) as r:
                        code, ctype, body = r.status, r.headers["Content-Type"], r.read()
                except urllib.error.HTTPError as exc:
                    code, ctype, body = exc.code, exc.headers["Content-Type"], exc.read()
                self.send_response(code)
                self.send_header("Content-Type", ctype)
                self.send_header("Content-Length", str(len(body)))
                self.end_headers()
                self.wfile.write(body)

            do_GET = do_POST = do_PUT = _forward

            def log_message(self, *args):
                pass

        self.server = http.server.ThreadingHTTPServer(("127.0.0.1", free_port(socket.SOCK_STREAM)), Handler)
        threading.Thread(target=self.server.serve_forever, daemon=True).start()
        self.url = f"http://127.0.0.1:{self.server.server_address[1]}{PREFIX}"

    def close(self) -> None:
        self.server.shutdown()
        self.server.server_close()


@pytest.mark.skipif(CHROMIUM is None, reason="Debian's chromium is not installed (make installs it where apt may)")
def test_the_page_under_blueos_relative_path_refuses_to_engage_and_keeps_a_setting_across_a_restart(tmp_path):
    sync_api = pytest.importorskip("playwright.sync_api", reason="playwright (the browser driver) is not installed")
    nobody = f"udpout:127.0.0.1:{free_port()}"                  # no vehicle on the other end
    proxy, ext = Proxy(), Extension(tmp_path, nobody, "--register-endpoint", "none", "--identity-timeout", "1")
    endpoint = "tcp/10.0.0.7:7447"
    try:
        proxy.target = ext.url
        with sync_api.sync_playwright() as p:
            browser = p.chromium.launch(executable_path=CHROMIUM, args=FLAGS, headless=True)
            page = browser.new_page()
            page.goto(proxy.url)
            assert page.title() == "Wavekeep"
            link = page.locator("#link")
            sync_api.expect(link).to_contain_text("no link", timeout=15_000)
            page.click("#engage")
            sync_api.expect(page.locator("#message")).to_contain_text("not engaged", timeout=10_000)
            sync_api.expect(page.locator("#law option")).to_have_count(3)
            page.select_option("#law", "cpd_ff")
            page.select_option("#method", "servo")
            page.fill("#forecast_endpoint", endpoint)
            page.click("#save")
            sync_api.expect(page.locator("#settings_message")).to_contain_text("saved", timeout=10_000)
            assert ext.stop() == 0, ext.log()
            ext = Extension(tmp_path, nobody, "--register-endpoint", "none", data=tmp_path / "data")
            proxy.target = ext.url
            page.goto(proxy.url)
            sync_api.expect(page.locator("#law")).to_have_value("cpd_ff", timeout=10_000)
            sync_api.expect(page.locator("#method")).to_have_value("servo")
            sync_api.expect(page.locator("#forecast_endpoint")).to_have_value(endpoint)
            sync_api.expect(page.locator("#forecast")).to_contain_text(f"no valid forecast from {endpoint}",
                                                                       timeout=10_000)
            browser.close()
        assert proxy.outside == [] or proxy.outside == ["/favicon.ico"], proxy.outside
    finally:
        ext.stop()
        proxy.close()
