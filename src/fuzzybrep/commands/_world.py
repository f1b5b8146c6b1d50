"""The floor plan and route that ``simulate`` and ``demo`` share: --world, --route and --spacing,
declared and resolved in one place.

Not a command itself (cli.COMMANDS does not list it).
"""

from __future__ import annotations

import argparse

from ..errors import WorldError
from ..sim.world import Route, World, builtin_floor, builtin_route, check_route


def add_world_arguments(p: argparse.ArgumentParser, title: str) -> None:
    """--world, --route and --spacing, in an argument group named ``title``."""
    g = p.add_argument_group(title)
    g.add_argument("--world", metavar="FILE.geojson",
                   help="floor plan, GeoJSON in metres (default: the built-in E1-like floor)")
    g.add_argument("--route", metavar="FILE",
                   help="route: GeoJSON LineString (role route) or CSV of x,y waypoints in metres; "
                        "default: the world file's route feature, or the built-in clockwise route")
    g.add_argument("--spacing", type=float, default=None, help="metres between stops (default: the route's, else 5)")


def world_and_route(args: argparse.Namespace) -> tuple[World, Route, str]:
    """The world, its route and where the world came from (the file, or "built-in").

    The route is --route's file, else the world file's route feature, else the built-in route;
    its stops every --spacing metres if given, else as the file says, else 5 m.
    """
    world = World.from_geojson(args.world) if args.world else builtin_floor()
    if args.route:
        route = Route.from_file(args.route, args.spacing)
    elif args.world:
        try:
            route = Route.from_file(args.world, args.spacing)
        except WorldError as e:
            raise WorldError(f"{e.reason} (pass --route, or give the world file a route feature)", args.world,
                             e.feature) from None
    else:
        route = builtin_route(5.0 if args.spacing is None else args.spacing)
    try:
        check_route(world, route)  # here, where the files are known: the error names them
    except WorldError as e:
        world_name = args.world or "built-in floor"
        raise WorldError(f"{e.reason} (world: {world_name})", args.route or args.world, e.feature) from None
    return world, route, str(args.world) if args.world else "built-in"
