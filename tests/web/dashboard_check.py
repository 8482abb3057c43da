"""Drives the dashboard in a real headless Chromium, as a user would, through the DevTools
protocol (a minimal WebSocket client on the standard library, so nothing beyond Debian's
chromium and python3 is needed). Prints what it saw as JSON for the C++ test to check.

usage: python3 dashboard_check.py URL TOKEN STUDY_FILE FINISHED_STUDY_ID
  URL: the server; TOKEN: its token; STUDY_FILE: a study to submit through the page (one whose
  runs take long enough to cancel); FINISHED_STUDY_ID: a study whose runs are complete.
"""
import base64
import json
import os
import shutil
import signal
import socket
import struct
import subprocess
import sys
import tempfile
import time
import urllib.request


class Page:
    """One page over the DevTools WebSocket: evaluate JavaScript, wait for conditions."""

    def __init__(self, ws_url):
        host_port, path = ws_url[len("ws://"):].split("/", 1)
        host, port = host_port.split(":")
        self.sock = socket.create_connection((host, int(port)), timeout=30)
        key = base64.b64encode(os.urandom(16)).decode()
        self.sock.sendall((f"GET /{path} HTTP/1.1\r\nHost: {host_port}\r\nUpgrade: websocket\r\n"
                           f"Connection: Upgrade\r\nSec-WebSocket-Key: {key}\r\n"
                           "Sec-WebSocket-Version: 13\r\n\r\n").encode())
        reply = b""
        while b"\r\n\r\n" not in reply:
            reply += self.sock.recv(4096)
        if b" 101 " not in reply.split(b"\r\n")[0]:
            raise RuntimeError("no WebSocket upgrade: " + reply.decode(errors="replace"))
        self.buffer = reply.split(b"\r\n\r\n", 1)[1]
        self.next_id = 0
        self.events = []  # the browser's events (no id), kept in order for wait_event

    def _send(self, text):
        data = text.encode()
        mask = os.urandom(4)
        header = bytes([0x81])
        if len(data) < 126:
            header += bytes([0x80 | len(data)])
        elif len(data) < 65536:
            header += bytes([0x80 | 126]) + struct.pack(">H", len(data))
        else:
            header += bytes([0x80 | 127]) + struct.pack(">Q", len(data))
        self.sock.sendall(header + mask + bytes(b ^ mask[i % 4] for i, b in enumerate(data)))

    def _read(self, n):
        while len(self.buffer) < n:
            chunk = self.sock.recv(65536)
            if not chunk:
                raise RuntimeError("the browser closed the connection")
            self.buffer += chunk
        out, self.buffer = self.buffer[:n], self.buffer[n:]
        return out

    def _receive(self):
        message = b""
        while True:
            b0, b1 = self._read(2)
            length = b1 & 0x7F
            if length == 126:
                length = struct.unpack(">H", self._read(2))[0]
            elif length == 127:
                length = struct.unpack(">Q", self._read(8))[0]
            message += self._read(length)
            if b0 & 0x80:
                return json.loads(message)

    def call(self, method, **params):
        self.next_id += 1
        self._send(json.dumps({"id": self.next_id, "method": method, "params": params}))
        while True:
            reply = self._receive()
            if "id" not in reply:
                self.events.append(reply)
            elif reply["id"] == self.next_id:
                if "error" in reply:
                    raise RuntimeError(f"{method}: {reply['error']}")
                return reply["result"]

    def js(self, expression):
        result = self.call("Runtime.evaluate", expression=expression, awaitPromise=True,
                           returnByValue=True)
        if "exceptionDetails" in result:
            raise RuntimeError(f"{expression}: {result['exceptionDetails']}")
        return result["result"].get("value")

    def wait(self, expression, timeout=30.0):
        """Polls until the expression is truthy; returns its value, or None on a timeout."""
        end = time.time() + timeout
        while time.time() < end:
            value = self.js(expression)
            if value:
                return value
            time.sleep(0.1)
        return None

    def wait_event(self, method, timeout=30.0):
        """The first event named `method` not yet taken; None after `timeout` seconds."""
        end = time.time() + timeout
        while time.time() < end:
            for k, event in enumerate(self.events):
                if event.get("method") == method:
                    return self.events.pop(k)
            self.js("true")  # reads what the browser sent meanwhile
            time.sleep(0.05)
        return None


def main():
    url, token, study_file, finished = sys.argv[1:5]
    profile = tempfile.mkdtemp(prefix="millsim-chromium-")
    browser = subprocess.Popen(
        ["chromium", "--headless", "--no-sandbox", "--disable-gpu", "--no-first-run",
         f"--user-data-dir={profile}", "--remote-debugging-port=0", "about:blank"],
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
    seen = {}
    try:
        port_file = os.path.join(profile, "DevToolsActivePort")
        for _ in range(300):
            if os.path.exists(port_file) and open(port_file).read().strip():
                break
            time.sleep(0.1)
        port = int(open(port_file).read().split()[0])
        targets = json.load(urllib.request.urlopen(f"http://127.0.0.1:{port}/json/list"))
        page = Page(next(t for t in targets if t["type"] == "page")["webSocketDebuggerUrl"])
        page.call("Page.navigate", url=url + "/")

        # The studies: each with its progress bar; names as text, never as markup.
        seen["studies"] = page.wait(
            "Array.from(document.querySelectorAll('#studies tr.study')).map(r => ({"
            "id: r.dataset.id, name: r.cells[1].textContent, markup_in_name: r.cells[1].children.length,"
            "complete: r.cells[4].textContent, bar: r.querySelector('.bar') !== null}))"
            ".filter(s => s.complete.length > 0)")

        # Submit through the page with the token, then land on the new study. The token's change
        # refreshes the list; that refresh is held unanswered (DevTools' Fetch interception) until
        # the page shows the new study, as on a loaded server, and must not draw the list over it.
        page.call("Fetch.enable", patterns=[{"urlPattern": "*/v1/studies?limit=*"}])
        study_text = open(study_file).read()
        page.js(f"document.getElementById('token').value = {json.dumps(token)};"
                "document.getElementById('token').dispatchEvent(new Event('change'));"
                "true")
        held = page.wait_event("Fetch.requestPaused")
        seen["list_refresh_held"] = held is not None
        page.wait("document.getElementById('study-text') !== null")
        page.js(f"document.getElementById('study-text').value = {json.dumps(study_text)};"
                "document.getElementById('submit').click(); true")
        seen["submitted_hash"] = page.wait(
            "location.hash.startsWith('#/studies/') && document.querySelector('#results') "
            "? location.hash : ''")
        seen["submitted_rows"] = page.js("document.querySelectorAll('#results tr.clickable').length")
        list_fetches = ("performance.getEntriesByType('resource')"
                        ".filter(e => e.name.includes('/v1/studies?limit=')).length")
        fetched_before = page.js(list_fetches)
        page.js("window.listDrawn = false; new MutationObserver(() => {"
                "const h = document.querySelector('#main h1');"
                "if (h && h.textContent === 'Studies') window.listDrawn = true;"
                "}).observe(document.getElementById('main'), {childList: true}); true")
        while held is not None:
            page.call("Fetch.continueRequest", requestId=held["params"]["requestId"])
            held = page.wait_event("Fetch.requestPaused", timeout=0.5)
        page.call("Fetch.disable")
        seen["held_list_answered"] = bool(page.wait(f"{list_fetches} > {fetched_before}"))
        time.sleep(0.5)  # the held refresh's own continuation, had it anything left to draw
        seen["list_drawn_over_study"] = page.js("window.listDrawn")

        study_id = seen["submitted_hash"][len("#/studies/"):]

        def api_study():
            with urllib.request.urlopen(f"{url}/v1/studies/{study_id}", timeout=30) as r:
                return json.load(r)

        def set_token(value):
            page.js(f"document.getElementById('token').value = {json.dumps(value)};"
                    "document.getElementById('token').dispatchEvent(new Event('change')); true")

        # A Cancel refused by the server (a wrong token: 401) stays on the page through the
        # refreshes (every 3 s) until it is dismissed. The page asks before it cancels.
        page.js("window.confirm = (m) => { window.askedToConfirm = m; return true; }; true")
        set_token("wrong-token")
        page.wait("document.querySelector('button.cancel') !== null")
        page.js("document.querySelector('button.cancel').click(); true")
        seen["refused_notice"] = page.wait(
            "document.getElementById('notice') ? document.getElementById('notice').textContent : ''"
        ) or ""
        seen["confirm_question"] = page.js("window.askedToConfirm || ''")
        lost = page.js(
            "document.getElementById('results') ? (document.getElementById('results')"
            ".dataset.beforeRefresh = '1', '') : document.getElementById('main').textContent")
        if lost:
            raise RuntimeError(f"the study page has no results table beside the notice: {lost!r}")
        time.sleep(7)
        seen["refreshed"] = page.js(
            "document.getElementById('results') !== null && "
            "document.getElementById('results').dataset.beforeRefresh === undefined")
        seen["refused_notice_after_refreshes"] = page.js(
            "document.getElementById('notice') ? document.getElementById('notice').textContent : ''")
        page.js("const dismiss = document.querySelector('#notice button.dismiss');"
                "if (dismiss) dismiss.click(); true")
        seen["notice_dismissed"] = bool(page.wait("document.getElementById('notice') === null"))

        # With the token: a Cancel the user does not confirm sends nothing; a confirmed one cancels.
        set_token(token)
        page.js("window.confirm = () => false; true")
        page.wait("document.querySelector('button.cancel') !== null")
        page.js("document.querySelector('button.cancel').click(); true")
        time.sleep(1)
        seen["canceled_when_not_confirmed"] = api_study()["canceled"]
        page.js("window.confirm = () => true; true")
        page.wait("document.querySelector('button.cancel') !== null")
        page.js("document.querySelector('button.cancel').click(); true")
        seen["canceled_shown"] = bool(page.wait(
            "document.querySelector('#main h1') && document.getElementById('main').textContent"
            ".includes('(canceled)')"))

        # A finished study: results, both plots, and a run's PSD and log tail on a click.
        page.js(f"location.hash = '#/studies/{finished}'; true")
        page.wait("document.querySelectorAll('#results tr.clickable').length > 0 && "
                  f"document.querySelector('#main h1').textContent.includes('{finished}')")
        seen["finished_rows"] = page.js(
            "Array.from(document.querySelectorAll('#results tr.clickable')).map(r => ({"
            "run: r.dataset.run, state: r.cells[2].textContent, d50: r.cells[6].textContent,"
            "error: r.cells[8].textContent}))")
        seen["plots"] = page.wait(
            "Array.from(document.querySelectorAll('.plots img')).filter(i => i.complete && "
            "i.naturalWidth > 0).map(i => i.alt)")
        page.js("document.querySelector('#results tr.clickable').click(); true")
        seen["run_details"] = page.wait(
            "document.getElementById('run-details') && document.getElementById('log-tail') && "
            "document.querySelector('#run-details img') && "
            "document.querySelector('#run-details img').complete ? {"
            "spectrum: Array.from(document.querySelectorAll('#run-details img')).filter(i => "
            "i.naturalWidth > 0).map(i => i.alt),"
            "title: document.querySelector('#run-details h2').textContent,"
            "psd: (document.getElementById('run-details').textContent"
            ".match(/outlet PSD: d10 [^µ]*µm, d50 [^µ]*µm, d90 [^µ]*µm/) || [''])[0],"
            "psd_points: document.querySelector('#run-details svg.psd polyline') ? "
            "document.querySelector('#run-details svg.psd polyline').getAttribute('points').split(' ').length : 0,"
            "psd_texts: Array.from(document.querySelectorAll('#run-details svg.psd text')).map(t => t.textContent),"
            "log_tail: document.getElementById('log-tail').textContent} : null")

        # Back to the list: the submitted study's name, whatever it holds, is text.
        page.js("location.hash = '#/'; true")
        seen["studies_after"] = page.wait(
            "document.querySelectorAll('#studies tr.study').length > 1 && "
            "Array.from(document.querySelectorAll('#studies tr.study')).map(r => ({"
            "id: r.dataset.id, name: r.cells[1].textContent, markup_in_name: r.cells[1].children.length,"
            "state: r.cells[5].textContent}))")
    finally:
        os.killpg(browser.pid, signal.SIGKILL)
        browser.wait()
        shutil.rmtree(profile, ignore_errors=True)
    print(json.dumps(seen))


main()
