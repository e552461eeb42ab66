"""ROS consumers of a generated variant, for tests: run by Debian's /usr/bin/python3 (its rospy), ideally inside a
private network namespace. Starts Xvfb, rosmaster (127.0.0.1, given port), robot_state_publisher and RViz with the
variant's package on ROS_PACKAGE_PATH, publishes zero joint states, records every TF frame, screenshots RViz.

usage: consumers.py PACKAGE_DIR PORT DISPLAY OUT_DIR   (prints one JSON line)
"""

import json
import os
import subprocess
import sys
import time
import xml.etree.ElementTree as ET
from pathlib import Path

RVIZ_CONFIG = """Panels: []
Visualization Manager:
  Class: ""
  Displays:
    - {{Alpha: 1, Class: rviz/RobotModel, Enabled: true, Name: RobotModel, Robot Description: robot_description,
       TF Prefix: "", Update Interval: 0, Value: true, Visual Enabled: true, Collision Enabled: false}}
  Enabled: true
  Global Options: {{Background Color: 0; 0; 255, Fixed Frame: {root}, Frame Rate: 10}}
  Name: root
  Tools: []
  Value: true
  Views:
    Current: {{Class: rviz/Orbit, Distance: {distance}, Focal Point: {{X: 0, Y: 0, Z: {focus}}}, Name: Current View,
              Pitch: 0.3, Yaw: 0.8, Target Frame: <Fixed Frame>, Value: Orbit (rviz)}}
Window Geometry: {{Height: 600, Width: 800, X: 0, Y: 0}}
"""


def main(package_dir: str, port: str, display: str, out_dir: str) -> None:
    package = Path(package_dir)
    out = Path(out_dir)
    urdf_text = (package / f"{package.name}.urdf").read_text()
    robot = ET.fromstring(urdf_text)
    links = [link.get("name") for link in robot.findall("link")]
    children = {joint.find("child").get("link") for joint in robot.findall("joint")}
    root = next(name for name in links if name not in children)
    movable = [j.get("name") for j in robot.findall("joint") if j.get("type") != "fixed"]
    arm = any("shoulder" in name for name in movable)
    env = dict(
        os.environ,
        ROS_MASTER_URI=f"http://127.0.0.1:{port}",
        ROS_IP="127.0.0.1",
        ROS_HOSTNAME="127.0.0.1",
        ROS_PACKAGE_PATH=f"{package.parent}:/usr/share",
        DISPLAY=display,
        HOME=str(out / "home"),
        ROS_LOG_DIR=str(out / "log"),
        LIBGL_ALWAYS_SOFTWARE="1",
    )
    os.environ.update(env)
    (out / "home").mkdir(exist_ok=True)
    (out / "view.rviz").write_text(
        RVIZ_CONFIG.format(root=root, distance=2.2 if arm else 0.5, focus=0.3 if arm else 0.1)
    )
    procs = []

    def start(args: list[str], log: str) -> subprocess.Popen:
        handle = open(out / log, "w")
        proc = subprocess.Popen(args, env=env, stdout=handle, stderr=subprocess.STDOUT)
        procs.append(proc)
        return proc

    try:
        start(["Xvfb", display, "-screen", "0", "800x600x24", "-nolisten", "tcp", "+extension", "GLX"], "xvfb.log")
        start(["rosmaster", "--core", "-p", port], "master.log")
        import rospy
        from sensor_msgs.msg import JointState
        from tf2_msgs.msg import TFMessage

        deadline = time.monotonic() + 30
        while True:
            try:
                rospy.set_param("/robot_description", urdf_text)
                break
            except OSError:
                if time.monotonic() > deadline:
                    raise
                time.sleep(0.2)
        start(["/usr/lib/robot_state_publisher/robot_state_publisher"], "rsp.log")
        rviz = start(["rviz", "-d", str(out / "view.rviz")], "rviz.log")
        frames: set[str] = set()

        def record(message: TFMessage) -> None:
            for transform in message.transforms:
                frames.add(transform.header.frame_id.lstrip("/"))
                frames.add(transform.child_frame_id.lstrip("/"))

        rospy.init_node("svhdesc_consumers_test", anonymous=True, disable_signals=True)
        rospy.Subscriber("/tf", TFMessage, record)
        rospy.Subscriber("/tf_static", TFMessage, record)
        states = rospy.Publisher("/joint_states", JointState, queue_size=1)
        started = time.monotonic()
        # RViz in software GL takes a while to load every mesh; the picture is taken once frames and meshes are in.
        while time.monotonic() - started < 45:
            message = JointState(name=movable, position=[0.0] * len(movable))
            message.header.stamp = rospy.Time.now()
            states.publish(message)
            time.sleep(0.1)
            if time.monotonic() - started > 20 and set(links) <= frames:
                break
        time.sleep(5)
        xwd = subprocess.run(["xwd", "-root", "-silent", "-display", display], capture_output=True, check=True)
        ppm = subprocess.run(["xwdtopnm"], input=xwd.stdout, capture_output=True, check=True)
        (out / "rviz.ppm").write_bytes(ppm.stdout)
        print(json.dumps({"links": links, "frames": sorted(frames), "rviz_alive": rviz.poll() is None, "root": root}))
    finally:
        for proc in reversed(procs):
            proc.terminate()
        for proc in procs:
            try:
                proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                proc.kill()


if __name__ == "__main__":
    main(*sys.argv[1:5])
