"""Vehicles: parts that add their own MJCF subtree to the world and return its handles.

A new vehicle is one module defining a :class:`~sim.vehicles.base.Vehicle` subclass (its ``kind``,
its :class:`~sim.vehicles.base.VehicleDims` and its geoms) plus one line in :data:`VEHICLES`.
"""
from __future__ import annotations

from sim.errors import SimError
from sim.vehicles.base import (BODY_NAME, IMU_SITE, VEHICLE_GROUP, Vehicle, VehicleDims,  # noqa: F401
                               VehicleHandles, camera_name)
from sim.vehicles.car import CAR, Car
from sim.vehicles.cart import CART, Cart
from sim.vehicles.drone import Drone
from sim.vehicles.handheld import Handheld
from sim.vehicles.rover import ROVER, Rover

VEHICLES = {"cart": Cart, "rover": Rover, "car": Car, "handheld": Handheld, "drone": Drone}
VEHICLE_KINDS = tuple(VEHICLES)


def vehicle_class(kind: str) -> type:
    """The :class:`Vehicle` subclass of ``kind``; unknown kinds raise a one-line ``SimError``."""
    cls = VEHICLES.get(kind)
    if cls is None:
        raise SimError(f"vehicle: unknown kind {kind!r}; valid: {', '.join(VEHICLE_KINDS)}")
    return cls


def make_vehicle(kind: str, rig, name: str = BODY_NAME) -> Vehicle:
    """The vehicle ``kind`` carrying ``rig``, named (and name-scoped) ``name``."""
    return vehicle_class(kind)(rig, name)


def add_vehicle(spec, rig, kind: str = "cart") -> VehicleHandles:
    """Add vehicle ``kind`` carrying ``rig`` to ``spec``; returns its handles."""
    return make_vehicle(kind, rig).add_to(spec)


__all__ = ["BODY_NAME", "CAR", "CART", "Car", "Cart", "Drone", "Handheld",
           "IMU_SITE", "ROVER", "Rover", "VEHICLES", "VEHICLE_GROUP", "VEHICLE_KINDS",
           "Vehicle", "VehicleDims", "VehicleHandles", "add_vehicle", "camera_name", "make_vehicle", "vehicle_class"]
