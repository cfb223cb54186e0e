"""Streams a pose graph to the rrr_graphslam node (rospy): PoseGraphEdge + LoopCandidate messages in
node order, /clock, and the node's decisions collected back. Used by scripts/replay_posegraph and the
rostests."""

import time
from collections import defaultdict
from typing import Dict, List, Optional, Tuple

import rospy
from rosgraph_msgs.msg import Clock
from std_srvs.srv import Trigger

from rrr_graphslam.msg import LoopCandidate, LoopClosureDecision, PoseGraphEdge, RrrStatus

from .decision_stream import StreamRow
from .graph_io import PoseGraph
from .replay import Plan, information_row_major, plan_replay

VERDICT_NAMES = {LoopClosureDecision.ACCEPTED: "accepted", LoopClosureDecision.REJECTED: "rejected",
                 LoopClosureDecision.PENDING: "pending"}


class ReplayError(RuntimeError):
    pass


class PoseGraphReplay:
    """`node` is the node's namespace (e.g. /rrr_graphslam); inputs go to `edges_topic` and
    `candidates_topic`."""

    def __init__(self, node: str = "/rrr_graphslam", edges_topic: str = "pose_graph_edges",
                 candidates_topic: str = "loop_candidates", publish_clock: bool = True,
                 timeout: float = 60.0):
        self.node = node.rstrip("/")
        self.timeout = timeout
        self.edges_pub = rospy.Publisher(edges_topic, PoseGraphEdge, queue_size=100000)
        self.candidates_pub = rospy.Publisher(candidates_topic, LoopCandidate, queue_size=100000)
        self.clock_pub = rospy.Publisher("/clock", Clock, queue_size=10) if publish_clock else None
        self.status: Optional[RrrStatus] = None
        # arrival index -> (from, to, verdict, cluster, reason)
        self.final: Dict[int, Tuple[int, int, str, int, str]] = {}
        # Every decision message as it came, by arrival index (decision_stream.score_stream); nodes:
        # the nodes sent when it came (exact with lockstep), final: caused by ~finish.
        self.stream: List[StreamRow] = []
        self.nodes_sent = 0
        self.finishing = False
        self.decision_messages = 0
        self.sources = set()  # the decisions' candidate sources (LoopClosureDecision.source)
        rospy.Subscriber(self.node + "/status", RrrStatus, self._on_status, queue_size=100)
        rospy.Subscriber(self.node + "/decisions", LoopClosureDecision, self._on_decision, queue_size=100000)
        self.sent = 0

    def _on_status(self, msg: RrrStatus) -> None:
        self.status = msg

    def _on_decision(self, msg: LoopClosureDecision) -> None:
        self.decision_messages += 1
        self.sources.add(msg.source)
        self.stream.append(StreamRow(self.finishing, self.nodes_sent, msg.header.stamp.to_sec(), msg.candidate,
                                     VERDICT_NAMES.get(msg.previous_verdict, "pending"),
                                     VERDICT_NAMES.get(msg.verdict, "pending"), msg.cluster,
                                     msg.reason))
        self.final[msg.candidate] = (msg.from_id, msg.to_id, VERDICT_NAMES.get(msg.verdict, "pending"),
                                     msg.cluster, msg.reason)

    def _wait(self, condition, what: str) -> None:
        deadline = time.monotonic() + self.timeout
        while not condition():
            if rospy.is_shutdown():
                raise ReplayError("ROS shut down while waiting for " + what)
            if time.monotonic() > deadline:
                raise ReplayError(f"timed out after {self.timeout:.0f} s waiting for {what}")
            time.sleep(0.001)

    def connect(self, reset: bool = True) -> None:
        """Waits for the node (its subscriptions and services) and, with `reset`, clears its graph."""
        self._wait(lambda: self.edges_pub.get_num_connections() > 0 and
                   self.candidates_pub.get_num_connections() > 0, "the node to subscribe")
        for name in ("reset", "finish"):
            rospy.wait_for_service(f"{self.node}/{name}", timeout=self.timeout)
        if reset:
            self.status = None
            self._wait(lambda: self.status is not None, "the node's status")
            self.call("reset")
            self.final.clear()
            self.stream.clear()
            self.decision_messages = 0
            self.sources.clear()
        self._wait(lambda: self.status is not None, "the node's status")
        self.baseline = 0 if reset else self.status.messages_processed

    def _processed(self) -> int:
        return (self.status.messages_processed - self.baseline) if self.status else -1

    def run(self, graph: PoseGraph, rate: float = 50.0, lockstep: bool = True, finish: bool = True,
            progress=None) -> Plan:
        """Sends every node (`rate` nodes per second of /clock and, unless lockstep, of wall time);
        in lockstep waits until the node has processed each node's messages."""
        plan = plan_replay(graph)
        sim = rospy.Time(1.0)
        period = rospy.Duration(1.0 / rate)
        next_wall = time.monotonic()
        for k, step in enumerate(plan.steps):
            if rospy.is_shutdown():
                raise ReplayError("ROS shut down")
            sim += period
            self.nodes_sent = k + 1
            if self.clock_pub:
                self.clock_pub.publish(Clock(clock=sim))
            if step.odometry is not None:
                o = step.odometry
                self._publish(self.edges_pub, PoseGraphEdge(from_id=o.source, to_id=o.target,
                                                            information=o.information), sim, o.measurement)
            for cand in step.candidates:
                if cand.duplicate_of is not None:
                    continue
                e = cand.edge
                msg = LoopCandidate(from_id=e.source, to_id=e.target, information=information_row_major(e.information),
                                    source="replay_posegraph", score=1.0)
                self._publish(self.candidates_pub, msg, sim, e.measurement)
            if lockstep:
                self._wait(lambda: self._processed() >= self.sent, f"node {step.node} to be processed")
            else:
                next_wall += 1.0 / rate
                delay = next_wall - time.monotonic()
                if delay > 0:
                    time.sleep(delay)
            if progress:
                progress(k + 1, len(plan.steps))
        self._wait(lambda: self._processed() >= self.sent, "the node to process every message")
        if finish:
            self.finishing = True
            self.call("finish")
        else:
            self.sync()
        return plan

    def _publish(self, publisher, msg, stamp, measurement) -> None:
        """Stamps a PoseGraphEdge or LoopCandidate, fills its measurement and sends it."""
        msg.header.stamp = stamp
        msg.measurement.x, msg.measurement.y, msg.measurement.theta = measurement
        publisher.publish(msg)
        self.sent += 1

    def call(self, service: str) -> str:
        """Calls a Trigger service of the node and waits until every decision it caused arrived."""
        handled = self.status.services_handled
        answer = rospy.ServiceProxy(f"{self.node}/{service}", Trigger)()
        if not answer.success:
            raise ReplayError(f"~{service} failed: {answer.message}")
        self._wait(lambda: self.status.services_handled > handled, f"the status after ~{service}")
        self.sync()
        return answer.message

    def sync(self) -> None:
        """Waits until every decision the node reported in its status has arrived."""
        self._wait(lambda: self.decision_messages >= self.status.decisions_published, "the decisions")

    def final_by_pair(self) -> Dict[Tuple[int, int], List[Tuple[int, str, int, str]]]:
        by_pair = defaultdict(list)
        for index, (a, b, verdict, cluster, reason) in self.final.items():
            by_pair[(a, b)].append((index, verdict, cluster, reason))
        return dict(by_pair)
