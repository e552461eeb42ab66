"""The node's message classes when real ROS 1 packages are importable (any machine with ros_control or
MoveIt has controller_manager_msgs and control_msgs): the real packages are generated here by genpy's own
generator from the definitions, as catkin does, and put first on the path."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from svhdesc.ros1.system import DIST_PACKAGES, ros_available
from tests.support import REPO

pytestmark = [pytest.mark.ros, pytest.mark.skipif(not ros_available(), reason="Debian's python3-rospy is absent")]

DEFINITIONS = REPO / "svhdesc" / "ros1" / "definitions" / "controller_manager_msgs"

GENERATE = """
import sys
sys.path.append({dist!r})
from genpy.generator import MsgGenerator, SrvGenerator
from genpy.generate_initpy import write_modules
pkg, src, out = 'controller_manager_msgs', sys.argv[1], sys.argv[2]
search = {{pkg: [src], 'std_msgs': ['/usr/share/std_msgs/msg']}}
import glob
for gen, ext, sub in ((MsgGenerator(), 'msg', 'msg'), (SrvGenerator(), 'srv', 'srv')):
    files = sorted(glob.glob(src + '/*.' + ext))
    assert gen.generate_messages(pkg, files, out + '/' + pkg + '/' + sub, search) == 0
    write_modules(out + '/' + pkg + '/' + sub)
open(out + '/' + pkg + '/__init__.py', 'w').close()
"""

PROBE = """
from svhdesc.ros1.messages import controller_manager_msgs
cm = controller_manager_msgs()
state = cm.ControllerState(name='a', state='running', type='t',
                           claimed_resources=[cm.HardwareInterfaceResources('i', ['j'])])
response = cm.ListControllersResponse(controller=[state])
print(cm.ListControllers.__module__, response.controller[0].claimed_resources[0].resources)
"""


def test_a_real_controller_manager_msgs_package_is_used(tmp_path: Path) -> None:
    """Seeded fault: messages.py's former ``SimpleNamespace(**vars(msg), **vars(srv))`` fails here with
    ``TypeError: ... got multiple values for keyword argument '__name__'``."""
    subprocess.run(
        [sys.executable, "-c", GENERATE.format(dist=DIST_PACKAGES), str(DEFINITIONS), str(tmp_path)], check=True
    )
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(tmp_path), str(REPO), os.environ.get("PYTHONPATH", "")])}
    done = subprocess.run([sys.executable, "-c", PROBE], env=env, capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.split()[0] == "controller_manager_msgs.srv._ListControllers"  # the real one, not ours
    assert "['j']" in done.stdout
