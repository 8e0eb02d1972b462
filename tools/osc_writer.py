#!/usr/bin/env python3
"""A small OpenSCENARIO XML writer (stdlib only): elements, the document frame and the few actions,
conditions and storyboard pieces the standard suites and the test fixtures use.
`tools/suite_cases.py` writes the suites and `tools/fixture_cases.py` eight of the fixtures in
tests/data/openscenario/ with it; it is not a runnable tool itself.
"""

DATE = "2026-12-01T00:00:00"


def escape(value):
    """An attribute value with `&`, `<`, `>` and `"` written as entities."""
    return str(value).replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;").replace('"', "&quot;")


class X:
    """A tiny XML element: tag, attributes (in order), children; written with 2-space indents."""

    def __init__(self, tag, *children, **attrs):
        self.tag, self.children, self.attrs = tag, list(children), attrs

    def lines(self, depth=0):
        pad = "  " * depth
        attrs = "".join(f' {k.rstrip("_")}="{escape(v)}"' for k, v in self.attrs.items())
        if not self.children:
            return [f"{pad}<{self.tag}{attrs}/>"]
        out = [f"{pad}<{self.tag}{attrs}>"]
        for c in self.children:
            out.extend(c.lines(depth + 1))
        out.append(f"{pad}</{self.tag}>")
        return out


def walk(el):
    """`el` and every element below it."""
    yield el
    for c in el.children:
        yield from walk(c)


def check_revision(minor, body):
    """What the schema of revision 1.`minor` forbids and the writer could produce: an `Act` without a
    `StartTrigger` (optional only from 1.3), an expression `${...}` (from 1.1). ASAM's checker
    (tools/asam_qc.py) would flag both; the writer refuses them first, naming the element."""
    for el in (e for b in body for e in walk(b)):
        if minor < 3 and el.tag == "Act" and not any(c.tag == "StartTrigger" for c in el.children):
            raise ValueError(f"Act {el.attrs.get('name')!r}: a StartTrigger is required before revision 1.3")
        if minor < 1:
            for k, v in el.attrs.items():
                if "${" in str(v):
                    raise ValueError(f"{el.tag}@{k.rstrip('_')} = {v!r}: expressions need revision 1.1 or later")


def document(comment, minor, description, *body):
    if "--" in comment:
        raise ValueError("an XML comment cannot hold `--`")
    check_revision(minor, body)
    head = X("FileHeader", revMajor="1", revMinor=str(minor), date=DATE, author="flc", description=description)
    text = "\n".join(X("OpenSCENARIO", head, *body).lines())
    return f'<?xml version="1.0" encoding="UTF-8"?>\n<!-- {comment.strip()}\n-->\n{text}\n'


def params(*decls):
    """ParameterDeclarations: each a `(name, type, value)` or an element (`constrained`)."""
    return X("ParameterDeclarations", *[d if isinstance(d, X) else X("ParameterDeclaration", name=d[0], parameterType=d[1], value=d[2])
                                        for d in decls])


def constrained(name, type_, value, *groups):
    """A ParameterDeclaration with ConstraintGroups, each a list of `(rule, value)` (ANDed in a
    group, the groups ORed)."""
    return X("ParameterDeclaration", *[X("ConstraintGroup", *[X("ValueConstraint", rule=r, value=v) for r, v in g]) for g in groups],
             name=name, parameterType=type_, value=value)


def catalog_locations(**dirs):
    """CatalogLocations: `vehicle="catalogs"` -> <VehicleCatalog><Directory path="catalogs"/>."""
    return X("CatalogLocations", *[X(f"{k.capitalize()}Catalog", X("Directory", path=d)) for k, d in dirs.items()])


def road_network(path):
    return X("RoadNetwork", X("LogicFile", filepath=path))


def assignments(pairs):
    return X("ParameterAssignments", *[X("ParameterAssignment", parameterRef=n, value=v) for n, v in pairs])


def catalog_ref(catalog, entry, *pairs):
    """A CatalogReference with ParameterAssignments `(name, value)` (none: an empty element)."""
    return X("CatalogReference", *([assignments(pairs)] if pairs else []), catalogName=catalog, entryName=entry)


def catalog_object(name, entry, *pairs, controller=None):
    """A ScenarioObject from the VehicleCatalog (`entry`, parameters overridden by `pairs`), with an
    ObjectController from a catalog when `controller` = a CatalogReference."""
    more = [X("ObjectController", controller)] if controller is not None else []
    return X("ScenarioObject", catalog_ref("VehicleCatalog", entry, *pairs), *more, name=name)


def car(name, vehicle):
    """A 4.5 x 1.8 x 1.5 m passenger car, reference point on the rear axle, box centre 1.4 m ahead."""
    return X(
        "ScenarioObject",
        X(
            "Vehicle",
            X("BoundingBox", X("Center", x="1.4", y="0.0", z="0.75"), X("Dimensions", width="1.8", length="4.5", height="1.5")),
            X("Performance", maxSpeed="70.0", maxAcceleration="10.0", maxDeceleration="10.0"),
            X(
                "Axles",
                X("FrontAxle", maxSteering="0.5", wheelDiameter="0.6", trackWidth="1.6", positionX="2.8", positionZ="0.3"),
                X("RearAxle", maxSteering="0.0", wheelDiameter="0.6", trackWidth="1.6", positionX="0.0", positionZ="0.3"),
            ),
            X("Properties"),
            name=vehicle,
            vehicleCategory="car",
        ),
        name=name,
    )


def speed(target, shape="step", dimension="time", value="0.0"):
    return X(
        "PrivateAction",
        X("LongitudinalAction", X("SpeedAction", X("SpeedActionDynamics", dynamicsShape=shape, dynamicsDimension=dimension, value=value),
                                   X("SpeedActionTarget", X("AbsoluteTargetSpeed", value=target)))),
    )


def lane_position(lane, s, offset="0.0", road="1"):
    return X("LanePosition", roadId=road, laneId=str(lane), offset=offset, s=s)


def teleport_to(position):
    """A TeleportAction to `position` (a LanePosition, WorldPosition, Relative...Position element)."""
    return X("PrivateAction", X("TeleportAction", X("Position", position)))


def teleport(lane, s):
    return teleport_to(lane_position(lane, s))


def place(entity, lane, s, v, *more):
    return place_at(entity, lane_position(lane, s), v, *more)


def place_at(entity, position, v, *more):
    """Init of one entity: teleported to `position`, at speed `v` (None: no speed), then `more`."""
    return X("Private", teleport_to(position), *([speed(v)] if v is not None else []), *more, entityRef=entity)


def activate(longitudinal, lateral="false"):
    return X("PrivateAction", X("ControllerAction", X("ActivateControllerAction", longitudinal=longitudinal, lateral=lateral)))


def lane_change(target_entity, value, time="$LaneChangeTime"):
    """A sinusoidal LaneChangeAction by time to the lane `value` lanes left of `target_entity`'s."""
    return X("PrivateAction", X("LateralAction", X("LaneChangeAction",
        X("LaneChangeActionDynamics", dynamicsShape="sinusoidal", dynamicsDimension="time", value=time),
        X("LaneChangeTarget", X("RelativeTargetLane", entityRef=target_entity, value=value)))))


def condition(name, inner, edge="none", delay="0"):
    return X("Condition", inner, name=name, delay=delay, conditionEdge=edge)


def after(t, rule="greaterThan"):
    return X("ByValueCondition", X("SimulationTimeCondition", value=t, rule=rule))


def by_entity(entity, inner):
    return X("ByEntityCondition", X("TriggeringEntities", X("EntityRef", entityRef=entity), triggeringEntitiesRule="any"),
             X("EntityCondition", inner))


def gap_below(entity, of, value, coordinate_system="entity"):
    """`entity`'s longitudinal freespace distance to `of` below `value`, in `coordinate_system`
    (None: the attribute left out, as in revision 1.0, which does not have it)."""
    system = {} if coordinate_system is None else {"coordinateSystem": coordinate_system}
    return by_entity(entity, X("RelativeDistanceCondition", entityRef=of, value=value, freespace="true", rule="lessThan",
                               relativeDistanceType="longitudinal", **system))


def collides(entity, other):
    """`entity` collides with `other`."""
    return by_entity(entity, X("CollisionCondition", X("EntityRef", entityRef=other)))


def trigger(tag, *groups):
    return X(tag, *[X("ConditionGroup", *g) for g in groups])


def event(name, action_name, action, start, priority="override", count="1"):
    """An Event of one Action; `start` is a Condition or a list of them (one ANDed group)."""
    group = start if isinstance(start, list) else [start]
    return X("Event", X("Action", action, name=action_name), trigger("StartTrigger", group), name=name, priority=priority,
             maximumExecutionCount=count)


def maneuver_group(actor, maneuver, events, group_name=None):
    """A ManeuverGroup of one actor with one Maneuver of `events`."""
    return X("ManeuverGroup", X("Actors", X("EntityRef", entityRef=actor), selectTriggeringEntities="false"),
             X("Maneuver", *events, name=maneuver), name=group_name or f"{actor}Group", maximumExecutionCount="1")


def story(name, act, actor, maneuver, events, act_start=None, group_name=None):
    """A Story of one Act with one ManeuverGroup (`actor`, `maneuver`, `events`)."""
    return story_of(name, act, [maneuver_group(actor, maneuver, events, group_name)], act_start)


def story_of(name, act, groups, act_start=None):
    """A Story of one Act of the ManeuverGroups `groups`; `act_start` is the Act's StartTrigger
    condition (None: none)."""
    act_el = X("Act", *groups, *([trigger("StartTrigger", [act_start])] if act_start is not None else []), name=act)
    return X("Story", act_el, name=name)


def storyboard(init, stories, stop_groups):
    return X("Storyboard", X("Init", X("Actions", *init)), *stories, trigger("StopTrigger", *stop_groups))
