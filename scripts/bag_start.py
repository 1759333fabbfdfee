"""Starts a paused `rosbag play --pause` (or scene_camera with ~start_paused) once the test and
the pipeline listen.

The perception nodelets subscribe lazily (only when something downstream listens), and a
loaded machine can take longer than any fixed `--delay` to start the test node: a frame
played before the whole chain is connected is lost, and a one- or two-frame bag then has
nothing left to test. So the bag starts paused and is resumed only when (1) every one of the
test's subscribers is connected to its publisher and (2) the master lists a subscriber for
each of `bag_topics` (default: for at least one data topic the player advertises; a bag may
hold a second camera nobody listens to) and (3) each of `other_listeners` has a subscriber other
than the test itself: a pipeline stage the test does not feed (the arm planner listening to a
grasp planner's ~grasps) that connects after the first frame misses it.
"""
import time

import rosgraph
import rospy
from std_srvs.srv import SetBool

# Topics a bag player publishes that need no listener before playing.
_NO_LISTENER_NEEDED = ("/clock", "/tf", "/tf_static", "/rosout")


def _unheard_bag_topics(player):
    publishers, subscribers, _ = rosgraph.Master(rospy.get_name()).getSystemState()
    listened = {topic for topic, nodes in subscribers if nodes}
    # The player's own topics (scene_camera's ~status) are reports, not data.
    played = [topic for topic, nodes in publishers if player in nodes and topic not in _NO_LISTENER_NEEDED
              and not topic.startswith(player + "/")]
    return played, [topic for topic in played if topic not in listened]


def _without_other_listener(topics):
    _, subscribers, _ = rosgraph.Master(rospy.get_name()).getSystemState()
    others = {topic for topic, nodes in subscribers if [n for n in nodes if n != rospy.get_name()]}
    return [t for t in topics if t not in others]


def resume_when_listening(subscribers, pause_service="/bag_player/pause_playback", bag_topics=None, timeout_s=60.0,
                          other_listeners=()):
    """Waits (wall time) for the conditions above, then resumes the player; raises RuntimeError
    naming what never connected."""
    player = pause_service.rsplit("/", 1)[0] or "/"
    rospy.wait_for_service(pause_service, timeout=timeout_s)
    deadline = time.monotonic() + timeout_s
    while True:
        unconnected = [s.resolved_name for s in subscribers if s.get_num_connections() == 0]
        played, unheard = _unheard_bag_topics(player)
        if bag_topics:
            heard = not [t for t in bag_topics if t in unheard or t not in played]
        else:
            heard = len(unheard) < len(played)
        lonely = _without_other_listener(other_listeners)
        if not unconnected and heard and not lonely:
            break
        if time.monotonic() > deadline:
            raise RuntimeError("not started after %.0f s: test subscribers without a publisher %s; topics played %s, "
                               "needed %s, without a subscriber %s; without another listener %s"
                               % (timeout_s, unconnected, played, bag_topics or "any", unheard, lonely))
        time.sleep(0.05)
    # Registered with the master is not yet connected: give the last TCP handshakes a moment.
    time.sleep(0.5)
    rospy.ServiceProxy(pause_service, SetBool)(False)
