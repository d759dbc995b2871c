"""The subcommands listing what is installed and kept: ``presets``, ``materials``, ``cache``."""

from __future__ import annotations

from synth.errors import SynthError


def _cmd_presets(args):
    from synth.io.presets import available, read

    for name, path in available().items():
        try:
            desc = read(path).get("description", "")
        except SynthError as exc:
            desc = f"(unreadable: {exc})"
        print(f"{name:<28} {desc}")
    return 0


def _cmd_materials(args):
    from synth.physics import materials

    for m in (materials.get(n) for n in materials.names()):
        print(
            f"{m.name:<16} rho={m.density:>7g} kg/m^3  E={m.young / 1e9:>7.4g} GPa  "
            f"nu={m.poisson:<5g} damping={m.damping}"
        )
    return 0


def _cmd_cache(args):
    from synth.store import cache

    if args.action == "clear":
        n, freed = cache.clear_disk()
        print(f"{cache.cache_dir()}: {n} files deleted, {freed / 1e6:.1f} MB freed")
        return 0
    info = cache.disk_info()
    print(
        f"{info.directory}: {info.entries} entries, {info.bytes / 1e6:.1f} MB of at most "
        f"{info.max_bytes / 1e6:.0f} MB (SYNTH_CACHE_MAX_BYTES; least recently used evicted)"
    )
    for kind, (n, size) in info.by_kind.items():
        print(f"  {kind:<32} {n:>5} entries {size / 1e6:>9.1f} MB")
    return 0


def add_presets_parser(sub) -> None:
    p = sub.add_parser("presets", help="list the presets")
    p.set_defaults(func=_cmd_presets)


def add_materials_parser(sub) -> None:
    p = sub.add_parser("materials", help="list the built-in materials")
    p.set_defaults(func=_cmd_materials)


def add_cache_parser(sub) -> None:
    p = sub.add_parser("cache", help="the disk cache of plate modes and radiation gains")
    p.add_argument(
        "action",
        choices=["info", "clear"],
        help="info: entries and size; clear: delete every entry",
    )
    p.set_defaults(func=_cmd_cache)
