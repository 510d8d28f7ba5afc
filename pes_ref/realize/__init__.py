"""Realization: a designed surface becomes parts you can make, checked by simulating those parts.

``python -m pes_ref realize DESIGN.npz --as contact|heightfield --out DIR`` and
``python -m pes_ref evaluate DESIGN.npz --realized DIR/device.toml`` (``docs/realize.md``).
Modules, one idea each:

- :mod:`.extra`       the optional extras ``realize`` and ``mujoco`` and their pip lines
- :mod:`.regions`     the blocked region of a design: the contact level, chosen by a stated
                      rule (:data:`~pes_ref.realize.regions.CONTACT_RULES`), as polygons
- :mod:`.followers`   blocked polygons into two parts, per topology: a pin in a plate (a
                      plane), a pin in a drum cam's groove (a cylinder)
                      (:data:`~pes_ref.realize.followers.FOLLOWERS`)
- :mod:`.contact`     a contact realization: parts, the device file's tables, what is lost
- :mod:`.exports`     writing and reading back device.toml, DXF (ezdxf) and STL (trimesh)
- :mod:`.evaluation`  a design's own held-out evaluation on a realized device, under eq. (1)
                      or its parts in rigid contact (:data:`~pes_ref.realize.evaluation.ENGINES`; what each
                      design kind needs to be realized is its kind's entry,
                      :attr:`pes_ref.synthesis.kinds.DesignKind.realizable`)
- :mod:`.heightfield` a plate whose top is the energy, and a ball rolling on it
- :mod:`.mujoco_ball` the same balls on the plate in MuJoCo (its heightfield geom)
- :mod:`.drawing`     the parts at three positions
- :mod:`.realizations` the realizations by name (``--as``): their files, options, and each
                      one prepared, written, read back and checked
"""
