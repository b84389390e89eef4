#!/usr/bin/env python3
"""moa's pose stream (docs/formats/pose-stream.md) read from UDP, and put on a
ROS 2 topic as nav_msgs/Odometry when rclpy can be imported; without ROS it
prints each pose. Python's standard library only (ROS optional).

    moa live --config robot.yaml --mouse ... --pose-out udp:127.0.0.1:5600 &
    python3 examples/pose_bridge.py --port 5600            # prints, or publishes /odom
    python3 examples/pose_bridge.py --port 5600 --count 10 # ten lines, then ends

The ten-line reader, without the bridge:

    import json, socket
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.bind(("127.0.0.1", 5600))
    last = -1
    while True:
        p = json.loads(s.recv(65536))
        if p["seq"] != last + 1:
            print(f"lost {p['seq'] - last - 1} lines")
        last = p["seq"]
        print(f"t {p['t']:.3f} s  x {p['x']:+.3f} m  y {p['y']:+.3f} m  theta {p['theta']:+.3f} rad")
"""
import argparse
import json
import math
import socket


def covariance(values):
    """The line's 6x6 row-major covariance as nav_msgs wants it: 36 floats.
    moa writes null for a pose without one (dead reckoning); nav_msgs has no
    'unknown', so zeros go out (see docs/formats/pose-stream.md)."""
    return [0.0] * 36 if values is None else [float(v) for v in values]


def odometry_message(p, stamp):
    """nav_msgs/Odometry from one line: pose in 'odom', twist in 'base_link'."""
    from nav_msgs.msg import Odometry  # only with ROS

    m = Odometry()
    m.header.stamp = stamp
    m.header.frame_id = p["frame_id"]
    m.child_frame_id = p["child_frame_id"]
    m.pose.pose.position.x = p["x"]
    m.pose.pose.position.y = p["y"]
    # Rotation by theta about z: q = (cos(theta/2), 0, 0, sin(theta/2)).
    m.pose.pose.orientation.z = math.sin(p["theta"] / 2.0)
    m.pose.pose.orientation.w = math.cos(p["theta"] / 2.0)
    m.pose.covariance = covariance(p["pose_covariance"])
    m.twist.twist.linear.x = p["vx"]
    m.twist.twist.linear.y = p["vy"]
    m.twist.twist.angular.z = p["omega"]
    m.twist.covariance = covariance(p["twist_covariance"])
    return m


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--host", default="127.0.0.1", help="address to listen on")
    parser.add_argument("--port", type=int, default=5600, help="UDP port of --pose-out")
    parser.add_argument("--topic", default="odom", help="ROS topic (with rclpy)")
    parser.add_argument("--count", type=int, default=0, help="end after this many lines (0: never)")
    args = parser.parse_args()

    try:
        import rclpy  # noqa: F401 (ROS 2 present: publish)
    except ImportError:
        rclpy = None
    publish = None
    if rclpy is not None:
        from nav_msgs.msg import Odometry

        rclpy.init()
        node = rclpy.create_node("moa_pose_bridge")
        publisher = node.create_publisher(Odometry, args.topic, 10)

        def publish(p):
            publisher.publish(odometry_message(p, node.get_clock().now().to_msg()))

    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.bind((args.host, args.port))
    last, lost, n = -1, 0, 0
    while args.count == 0 or n < args.count:
        p = json.loads(s.recv(65536))
        lost += p["seq"] - last - 1
        last = p["seq"]
        n += 1
        if publish:
            publish(p)
        else:
            used = "+".join(p["used"])
            print(
                f"seq {p['seq']} t {p['t']:.3f} s  x {p['x']:+.4f} m  y {p['y']:+.4f} m  "
                f"theta {p['theta']:+.4f} rad  v ({p['vx']:+.3f}, {p['vy']:+.3f}) m/s  "
                f"omega {p['omega']:+.3f} rad/s  {p['source']} {used}",
                flush=True,
            )
    print(f"{n} lines read, {lost} lost (gaps in seq)", flush=True)


if __name__ == "__main__":
    main()
