"""A ROS 2 subscriber we did not write: Eclipse Cyclone DDS's Python binding (the DDS behind
ROS 2's rmw_cyclonedds) listening to one skin's wrench and temperature topics with the
standard ROS 2 types. Prints `ready` once its readers exist, then one JSON line per sample,
until `seconds` pass or `count` wrenches arrived.

    python dds_listen.py SERIAL_TOKEN SECONDS COUNT
"""

import json
import sys
import time
from dataclasses import dataclass

from cyclonedds.core import Policy, Qos
from cyclonedds.domain import DomainParticipant
from cyclonedds.idl import IdlStruct
from cyclonedds.idl.types import float64, int32, uint32
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic


@dataclass
class Time(IdlStruct, typename="builtin_interfaces::msg::dds_::Time_"):
    sec: int32
    nanosec: uint32


@dataclass
class Header(IdlStruct, typename="std_msgs::msg::dds_::Header_"):
    stamp: Time
    frame_id: str


@dataclass
class Vector3(IdlStruct, typename="geometry_msgs::msg::dds_::Vector3_"):
    x: float64
    y: float64
    z: float64


@dataclass
class Wrench(IdlStruct, typename="geometry_msgs::msg::dds_::Wrench_"):
    force: Vector3
    torque: Vector3


@dataclass
class WrenchStamped(IdlStruct, typename="geometry_msgs::msg::dds_::WrenchStamped_"):
    header: Header
    wrench: Wrench


@dataclass
class Temperature(IdlStruct, typename="sensor_msgs::msg::dds_::Temperature_"):
    header: Header
    temperature: float64
    variance: float64


def main(token, seconds, count):
    dp = DomainParticipant(0)
    # Keep every sample until taken: a busy machine may poll late.
    qos = Qos(Policy.Reliability.BestEffort, Policy.History.KeepLast(1000))
    readers = {
        "wrench": DataReader(dp, Topic(dp, f"rt/vistaf/{token}/wrench", WrenchStamped), qos=qos),
        "skin_temperature": DataReader(
            dp, Topic(dp, f"rt/vistaf/{token}/skin_temperature", Temperature), qos=qos
        ),
    }
    print("ready", flush=True)
    end = time.time() + seconds
    wrenches = 0
    while time.time() < end and wrenches < count:
        for leaf, reader in readers.items():
            for s in reader.take(N=64):
                line = {"topic": leaf, "sec": s.header.stamp.sec,
                        "nanosec": s.header.stamp.nanosec, "frame_id": s.header.frame_id}
                if leaf == "wrench":
                    wrenches += 1
                    line["force"] = [s.wrench.force.x, s.wrench.force.y, s.wrench.force.z]
                else:
                    line["temperature"] = s.temperature
                print(json.dumps(line), flush=True)
        time.sleep(0.02)


if __name__ == "__main__":
    main(sys.argv[1], float(sys.argv[2]), int(sys.argv[3]))
