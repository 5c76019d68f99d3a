#!/usr/bin/python3
"""`piezo view` bound beyond loopback (0.0.0.0, inside a network namespace
of its own with only its loopback up, so nothing is reachable from
elsewhere): the banner says the data needs the token; the pages load
without it, the data (/api/, /files/) only with it (query or header); a
Host it does not serve is refused, --allow-host adds one.

Usage: view_wide_bind_check.py PIEZO   (needs root for the namespace;
exit 77 when it cannot make one)
"""
import os
import re
import subprocess
import sys
import tempfile
import time
import urllib.error
import urllib.request

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "support"))
import peers  # noqa: E402

piezo = sys.argv[1]
if os.geteuid() != 0:
    print("SKIP: a network namespace needs root")
    sys.exit(77)
if "PIEZO_IN_NETNS" not in os.environ:
    # Again, inside a namespace of its own with only loopback up.
    r = subprocess.run(["unshare", "--net", "sh", "-c",
                        f"ip link set lo up && PIEZO_IN_NETNS=1 exec {sys.executable} "
                        f"{os.path.abspath(__file__)} {piezo}"], check=False)
    sys.exit(r.returncode)


def check(condition, what):
    if not condition:
        print("FAILED:", what)
        sys.exit(1)


def get(path, headers=None):
    request = urllib.request.Request(f"http://127.0.0.1:{port}{path}", headers=headers or {})
    try:
        with urllib.request.urlopen(request, timeout=5) as r:
            return r.status
    except urllib.error.HTTPError as e:
        return e.code


port = 18931
runs = tempfile.mkdtemp(prefix="view-wide-")
view = peers.spawn([piezo, "view", "--runs", runs, "--listen", f"0.0.0.0:{port}",
                         "--allow-host", "lab-pc"], stderr=subprocess.PIPE, text=True)
try:
    banner = view.stderr.readline()
    check("its data needs the token" in banner, "the banner says so: " + banner)
    token = re.search(r"token=([0-9a-f]+)", banner)
    check(token is not None, "the banner prints the token: " + banner)
    token = token.group(1)
    for _ in range(50):
        if get("/runs") == 200:
            break
        time.sleep(0.1)
    check(get("/runs") == 200, "a page loads without the token")
    check(get("/api/runs") == 403, "data without the token is refused")
    check(get(f"/api/runs?token={token}") == 200, "data with the token in the query")
    check(get("/api/runs", {"X-Piezo-Token": token}) == 200, "data with the token in a header")
    check(get(f"/api/runs?token={token}0") == 403, "a wrong token is refused")
    check(get(f"/api/runs?token={token}", {"Host": f"evil.example:{port}"}) == 403,
          "a Host it does not serve is refused, token or not")
    check(get(f"/api/runs?token={token}", {"Host": f"lab-pc:{port}"}) == 200,
          "--allow-host adds a name")
    print("ok")
finally:
    view.terminate()
    view.wait()
