"""Realization: a designed surface becomes parts you can make, checked by simulating those parts.

``python -m pes_ref realize DESIGN.npz --as contact|heightfield --out DIR`` and
``python -m pes_ref evaluate DESIGN.npz --realized DIR/device.toml`` (``docs/realize.md``).
Modules, one idea each:

- [`.extra`][pes_ref.realize.extra]       the optional extras ``realize`` and ``mujoco`` and their pip lines
- [`.regions`][pes_ref.realize.regions]     the blocked region of a design: the contact level, chosen by a stated
                      rule (`CONTACT_RULES`), as polygons
- [`.followers`][pes_ref.realize.followers]   blocked polygons into two parts, per topology: a pin in a plate (a
                      plane), a pin in a drum cam's groove (a cylinder)
                      (`FOLLOWERS`)
- [`.contact`][pes_ref.realize.contact]     a contact realization: parts, the device file's tables, what is lost
- [`.exports`][pes_ref.realize.exports]     writing and reading back device.toml, DXF (ezdxf) and STL (trimesh)
- [`.evaluation`][pes_ref.realize.evaluation]  a design's own held-out evaluation on a realized device, under eq. (1)
                      or its parts in rigid contact (`pes_ref.rigid.engines.ENGINES`; what each
                      design kind needs to be realized is its kind's entry,
                      `pes_ref.synthesis.kinds.registry.DesignKind.realizable`)
- [`.heightfield`][pes_ref.realize.heightfield] a plate whose top is the energy, and a ball rolling on it
- [`.mujoco_ball`][pes_ref.realize.mujoco_ball] the same balls on the plate in MuJoCo (its heightfield geom)
- [`.drawing`][pes_ref.realize.drawing]     the parts at three positions
- [`.realizations`][pes_ref.realize.realizations] the realizations by name (``--as``): their files, options, and each
                      one prepared, written, read back and checked
"""
