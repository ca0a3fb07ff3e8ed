"""An operator's word on a vehicle's task: out of service, or sent home.

Both hand back a task the vehicle holds and has not loaded (:func:`hand_back_unloaded`):
one it is on its way to pick, dwells at the pick station for, or was awarded while it
dwells at a drop station. The vehicle publishes ``task`` without it and ``returned``
with its id (:class:`~agv_app.vehicle.comeback.HandBack`), so the task desk has the
station auction it again (:mod:`agv_app.tasks.custody`): nothing is lost, and it is done
once, by whoever wins it. A loaded vehicle (it has left the pick station) keeps its
task and delivers it first: a load is never stranded.

A vehicle that hands back a task on its way to the pick station stops at the first
point of its route it can stop at without giving back floor it holds (clear of every
no-rest zone), else at the pick station, and drives home from there.

* Out of service (:func:`take_out_of_service`): it hands back, finishes a loaded task,
  parks at its home and bids for no task until brought back.
* Sent home (:func:`send_home`): it hands back and drives home; it bids for no task
  until it stands there, then takes tasks again. A loaded vehicle, or a failed one, is
  not sent home (:func:`send_home_refusal`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from agv_app.vehicle.comeback import hand_back

if TYPE_CHECKING:
    from agv_app.vehicle.controller import AgvController

__all__ = [
    "hand_back_unloaded",
    "loaded",
    "send_home",
    "send_home_refusal",
    "take_out_of_service",
]


def loaded(agv: AgvController) -> bool:
    """Whether the AGV carries its task's load: it has left the pick station (on its way
    to the drop station, or dwelling there)."""
    return agv.task is not None and agv.phase in ("to_drop", "at_drop")


def hand_back_unloaded(agv: AgvController) -> str | None:
    """Hand back the task the AGV holds and has not loaded, and turn it home.

    Returns:
        The id of the task handed back (None: it held none it had not loaded).
    """
    if agv.failed:
        return None
    node = agv.node
    pending = agv.pending_task
    if pending is not None:
        # Awarded while it dwells at a drop station or drives home: not started yet.
        agv.pending_task = None
        current = agv.task
        node.update_node_property("task", None if current is None else current.id)
        hand_back(agv, pending, loaded=False)
        agv.publish()
        return pending.id
    task = agv.task
    if task is None or loaded(agv):
        return None
    agv.task = None
    node.update_node_property("task", None)
    node.update_node_property("reached_pick", None)
    node.update_node_property("dropping_at", None)
    hand_back(agv, task, loaded=False)
    _turn_home(agv)
    agv.publish()
    return task.id


def _turn_home(agv: AgvController) -> None:
    """The AGV that was bound for a pick station heads home: standing, at once (its
    next idle step); driving, from the first point it can stop at."""
    agv._resume = None
    if agv._dest is None:
        agv.phase = "home"  # away from home: its next idle step drives it there
        return
    agv.phase = "to_home"
    _stop_early(agv)


def _stop_early(agv: AgvController) -> None:
    """End the route at its first point at or beyond everything the AGV holds or asks
    for and clear of every no-rest zone (as a turn for a task does); keep it if none."""
    route, plan, dest = agv._route, agv._plan, agv._dest
    if route is None or plan is None or dest is None or route.end != dest:
        return
    vehicle, book = agv.vehicle, agv.book
    reach = book.lock_end(default=vehicle.s)
    pending = book.request()
    if pending is not None:
        reach = max(reach, pending.end_s)
    for k in range(1, len(route.points) - 1):
        s = route.offsets[k] + agv._route_shift
        if s < reach - 1e-9 or any(lo - 1e-6 <= s <= hi + 1e-6 for lo, hi in plan.zones):
            continue
        vehicle.shorten_route(s)
        agv._plan = plan.cut(s)
        agv._route = agv.layout.route_through(route.points[: k + 1])
        agv._dest = route.points[k]
        return


def take_out_of_service(agv: AgvController) -> None:
    """Take no more tasks: hand back an unloaded task, deliver a loaded one, then park
    at home (its idle steps drive it there)."""
    agv.in_service = False
    hand_back_unloaded(agv)


def send_home_refusal(agv: AgvController) -> str | None:
    """Why the AGV cannot be sent home now (None: it can)."""
    if agv.failed:
        return f"{agv.node_id} has failed"
    if not agv.in_service:
        return f"{agv.node_id} takes no tasks (out of service or due for a charge)"
    if loaded(agv):
        return f"{agv.node_id} is loaded: it delivers to {agv.task and agv.task.drop} first"
    orders = getattr(agv, "book_of_orders", None)  # a VDA 5050 master control's vehicle
    if orders is not None and orders.active:
        return f"{agv.node_id} drives an order of its master control"
    return None


def send_home(agv: AgvController) -> str | None:
    """Hand back an unloaded task and drive home; take tasks again once there.

    Returns:
        The id of the task handed back (None: none).

    Raises:
        ValueError: the AGV cannot be sent home (:func:`send_home_refusal` says why).
    """
    refusal = send_home_refusal(agv)
    if refusal is not None:
        raise ValueError(refusal)
    agv.sent_home = True
    handed = hand_back_unloaded(agv)
    if agv._dest is None and agv.task is None and agv.point != agv.home:
        # Standing away from home with nothing to do: off at once (a vehicle of a master
        # control would stand there, waiting for its next order).
        agv.errands.go_home()
    return handed
