"""JupyterLab in a real browser for tests: what a person sees in a notebook, not what the kernel sends.

:class:`Lab` is a JupyterLab server (from PyPI) of the test's own: its home, settings, workspaces and
runtime files under a temporary folder, and a kernelspec of this venv's Python on the test master.
:class:`Browser` is Debian's Chromium, headless, driven by playwright (``executable_path``: playwright's
own browser downloads are not used). :class:`NotebookPage` is one notebook open in it: cells run from the
Run menu as a person runs them, found by their source, their outputs read from the page and screenshotted.

Nothing is left behind: the page's kernels are shut down through the server, the server and the browser
stop, and :meth:`Lab.stop` fails the test if a process of its runtime folder (a kernel) still runs.
"""

from __future__ import annotations

import json
import os
import secrets
import signal
import subprocess
import sys
import urllib.error
import urllib.request
from pathlib import Path
from typing import Any

import pytest
from helpers import free_port
from support import wait_for

#: Debian's Chromium (run.sh installs the package ``chromium``).
CHROMIUM = Path("/usr/bin/chromium")
#: Headless, as root, on a machine without a network: no sandbox (root), no GPU, and none of the
#: background connections Chromium makes at start (refused here, many at a time).
CHROMIUM_ARGS = ["--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run", "--disable-background-networking",
                 "--disable-component-update", "--disable-sync"]
TIMEOUT = 120  # s: JupyterLab's page takes 10 s to load on an idle machine of 2 cores; generous, finite


def require_browser() -> Any:
    """playwright's sync API, failing (not skipping) with what to do when the browser checks cannot run."""
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        pytest.fail("the browser checks need playwright and jupyterlab: bash run.sh test installs them "
                    "(pip install -e '.[browser]')")
    if not CHROMIUM.exists():
        pytest.fail(f"the browser checks need Debian's Chromium at {CHROMIUM}: bash run.sh test installs it "
                    "(apt-get install chromium)")
    return sync_playwright


def _processes_naming(text: str) -> dict[int, str]:
    """Living processes whose command line contains ``text`` (a folder of this test's own)."""
    found = {}
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            cmdline = (entry / "cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace")
            state = (entry / "stat").read_text().rsplit(")", 1)[1].split()[0]
        except OSError:
            continue
        if text in cmdline and state != "Z":
            found[int(entry.name)] = cmdline
    return found


class Lab:
    """A JupyterLab server serving ``root`` on a free port of 127.0.0.1, its kernels on ``master_uri``."""

    def __init__(self, root: Path, home: Path, master_uri: str) -> None:
        self.root, self.home = root, home
        self.token = secrets.token_hex(16)
        self.port = free_port()
        self.runtime = home / "runtime"
        data = home / "data"
        spec = data / "kernels" / "python3"  # the notebooks' own kernel name, here this venv's Python
        spec.mkdir(parents=True)
        (spec / "kernel.json").write_text(json.dumps({
            "argv": [sys.executable, "-m", "ipykernel_launcher", "-f", "{connection_file}"],
            "display_name": "Python 3 (ipyros tests)", "language": "python", "env": {"ROS_MASTER_URI": master_uri}}))
        settings = home / "settings" / "@jupyterlab" / "apputils-extension"
        settings.mkdir(parents=True)  # no "would you like news?" box over the cells
        (settings / "notification.jupyterlab-settings").write_text(
            json.dumps({"fetchNews": "false", "checkForUpdates": False}))
        env = {key: value for key, value in os.environ.items() if not key.startswith(("JUPYTER", "PYTHONSTARTUP"))}
        env.update(HOME=str(home), IPYTHONDIR=str(home / "ipython"), JUPYTER_CONFIG_DIR=str(home / "config"),
                   JUPYTER_DATA_DIR=str(data), JUPYTER_RUNTIME_DIR=str(self.runtime),
                   JUPYTERLAB_SETTINGS_DIR=str(home / "settings"), JUPYTERLAB_WORKSPACES_DIR=str(home / "workspaces"),
                   ROS_MASTER_URI=master_uri, MPLBACKEND="Agg")
        self.log = home / "lab.log"
        with self.log.open("w") as log:
            self.proc = subprocess.Popen(
                [sys.executable, "-m", "jupyterlab", "--no-browser", "--allow-root", "--ServerApp.ip=127.0.0.1",
                 f"--ServerApp.port={self.port}", "--ServerApp.port_retries=0", f"--ServerApp.root_dir={root}",
                 f"--IdentityProvider.token={self.token}",
                 "--LabApp.expose_app_in_browser=True"],  # window.jupyterapp: the kernel's state, the cells' models
                env=env, stdout=log, stderr=subprocess.STDOUT, start_new_session=True)
        try:
            wait_for(self._answers, timeout=TIMEOUT, interval=0.2, what=f"JupyterLab to answer ({self.log})")
        except BaseException:
            self.stop()
            raise

    def _answers(self) -> bool:
        if self.proc.poll() is not None:
            raise AssertionError(f"JupyterLab exited ({self.proc.returncode}): {self.log.read_text()[-2000:]}")
        try:
            self.api("GET", "api/status")
        except OSError:
            return False
        return True

    def url(self, path: str, query: str = "") -> str:
        return f"http://127.0.0.1:{self.port}/{path}?{query}{'&' * bool(query)}token={self.token}"

    def api(self, method: str, path: str, body: Any = None) -> Any:
        """One request to the server's REST API; its JSON answer (None for none)."""
        request = urllib.request.Request(f"http://127.0.0.1:{self.port}/{path}", method=method,
                                         data=None if body is None else json.dumps(body).encode(),
                                         headers={"Authorization": f"token {self.token}",
                                                  "Content-Type": "application/json"})
        with urllib.request.urlopen(request, timeout=30) as answer:
            body = answer.read()
        return json.loads(body) if body else None

    def shut_down_kernels(self) -> None:
        """Every session's kernel shut down, as the Kernel menu's "Shut Down All Kernels" does."""
        for session in self.api("GET", "api/sessions"):
            try:
                self.api("DELETE", f"api/sessions/{session['id']}")
            except urllib.error.HTTPError as error:
                if error.code != 404:  # gone meanwhile
                    raise

    def stop(self) -> None:
        """The kernels, then the server, stopped; fails if a kernel of its runtime folder still runs."""
        if self.proc.poll() is None:
            try:
                self.shut_down_kernels()
            except OSError:
                pass
            self.proc.terminate()  # the server stops at once on SIGTERM, its kernels with it
            try:
                self.proc.wait(30)
            except subprocess.TimeoutExpired:
                os.killpg(self.proc.pid, signal.SIGKILL)
                self.proc.wait()
        try:
            wait_for(lambda: not _processes_naming(str(self.runtime)), timeout=20,
                     what="the server's kernels to exit")
        except AssertionError:
            left = _processes_naming(str(self.runtime))
            for pid in left:
                os.kill(pid, signal.SIGKILL)
            pytest.fail(f"JupyterLab left kernels running: {left}")


class Browser:
    """Debian's Chromium, headless, driven by playwright; its home is a folder of the test's own."""

    def __init__(self, home: Path) -> None:
        self._playwright = require_browser()().start()
        try:
            self._browser = self._playwright.chromium.launch(
                executable_path=str(CHROMIUM), headless=True, args=CHROMIUM_ARGS,
                env={**os.environ, "HOME": str(home)})
        except BaseException:
            self._playwright.stop()
            raise

    def page(self) -> Any:
        return self._browser.new_page(viewport={"width": 1400, "height": 1000})

    def close(self) -> None:
        try:
            self._browser.close()
        finally:
            self._playwright.stop()


# What the notebook panel of ``name`` says, read through JupyterLab's own objects (window.jupyterapp): false
# while the panel in view is another one, or none yet.
_PANEL = """const panel = window.jupyterapp && window.jupyterapp.shell.currentWidget;
  if (!panel || !panel.context || panel.context.path !== name || !panel.content) return false;"""
_KERNEL_IDLE = f"""(name) => {{ {_PANEL}
  const kernel = panel.sessionContext.session && panel.sessionContext.session.kernel;
  return !!kernel && kernel.status === 'idle'; }}"""
_ALL_RAN = f"""(name) => {{ {_PANEL}
  const code = panel.content.widgets.filter(cell => cell.model.type === 'code');
  return code.length > 0 && code.every(cell => Number.isInteger(cell.model.executionCount)); }}"""
_RAN = f"(name) => ({_ALL_RAN})(name) && ({_KERNEL_IDLE})(name)"
_CELL_INDEX = f"""([name, source]) => {{ {_PANEL}
  return panel.content.widgets.findIndex(cell => cell.model.sharedModel.getSource().includes(source)); }}"""
#: Outputs a person reads as errors: a traceback, or text written to stderr.
ERROR_OUTPUTS = ('.jp-OutputArea-output[data-mime-type="application/vnd.jupyter.stderr"], '
                 '.jp-OutputArea-output[data-mime-type="application/vnd.jupyter.error"]')


class NotebookPage:
    """The notebook at ``name`` (relative to the lab's root) open in a page of ``browser``, its kernel idle; when
    it closes, a screenshot of the page as it was last is left in ``shots`` (what went wrong, when a test fails).

    Its kernel is started by the server before the page opens (JupyterLab then asks no "Select Kernel" question
    while it is still learning the kernelspecs), and the page opens in a workspace of its own, reset: no tab of
    an earlier page comes back with it."""

    def __init__(self, lab: Lab, browser: Browser, name: str, shots: Path) -> None:
        self.lab, self.name, self.shots = lab, name, shots
        self.page = browser.page()
        try:
            lab.api("POST", "api/sessions", {"path": name, "name": name, "type": "notebook",
                                             "kernel": {"name": "python3"}})
            self.page.goto(lab.url(f"lab/workspaces/{Path(name).stem}/tree/{name}", "reset"))
            self.page.wait_for_function(_KERNEL_IDLE, arg=name, timeout=TIMEOUT * 1000, polling=200)
        except BaseException:
            self.close()
            raise

    def run_all(self) -> None:
        """Run > Run All Cells, as a person clicks it."""
        self.page.get_by_role("menuitem", name="Run", exact=True).click()
        self.page.get_by_role("menuitem", name="Run All Cells", exact=True).click()

    def ran(self) -> bool:
        """Whether every code cell has run and the kernel is idle again."""
        return self.page.evaluate(_RAN, self.name)

    def cell(self, source: str) -> Any:
        """The first cell whose source contains ``source``, as a playwright locator, scrolled into view (the
        notebook renders only what is in view: text out of it reads as empty)."""
        index = self.page.evaluate(_CELL_INDEX, [self.name, source])
        assert index is not False and index >= 0, f"no cell of {self.name} holds {source!r}"
        cell = self.page.locator(".jp-Notebook .jp-Cell").nth(index)
        cell.scroll_into_view_if_needed()
        return cell

    def saved(self) -> Any:
        """The notebook as File > Save Notebook writes it now, outputs and all (an ``nbformat`` notebook): what the
        page shows, for the checks a kernel's run gets (tests/support/notebooks.py)."""
        import nbformat

        before = self.lab.api("GET", f"api/contents/{self.name}?content=0")["last_modified"]
        self.page.get_by_role("menuitem", name="File", exact=True).click()
        self.page.get_by_role("menuitem", name="Save Notebook", exact=False).first.click()
        wait_for(lambda: self.lab.api("GET", f"api/contents/{self.name}?content=0")["last_modified"] != before,
                 timeout=TIMEOUT, interval=0.2, what=f"{self.name} saved")
        return nbformat.from_dict(self.lab.api("GET", f"api/contents/{self.name}")["content"])

    def errors(self) -> list[str]:
        """The text of every error output on the page (tracebacks, stderr)."""
        return self.page.locator(ERROR_OUTPUTS).all_inner_texts()

    def close(self) -> None:
        """The page closed, as it was last in a screenshot, and the notebook's kernel shut down."""
        try:
            self.page.screenshot(path=str(self.shots / f"{Path(self.name).stem}-last.png"))
        finally:
            self.page.close()
        for session in self.lab.api("GET", "api/sessions"):
            if session["path"] == self.name:
                self.lab.api("DELETE", f"api/sessions/{session['id']}")
