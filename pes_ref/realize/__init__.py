"""Realization: a designed surface becomes parts you can make, checked by simulating those parts.

``python -m pes_ref realize DESIGN.npz --as contact|heightfield --out DIR`` and
``python -m pes_ref evaluate DESIGN.npz --realized DIR/device.toml`` (``docs/realize.md``).
Modules, one idea each:

- :mod:`.extra`       the optional extra ``realize`` (ezdxf, trimesh) and its pip line
- :mod:`.regions`     the blocked region of a design: the contact level, chosen by a stated
                      rule (:data:`~pes_ref.realize.regions.CONTACT_RULES`), as polygons
- :mod:`.followers`   blocked polygons into two parts: a pin in a plate (a plane), a pin in a
                      drum's groove (a cylinder) (:data:`~pes_ref.realize.followers.FOLLOWERS`)
- :mod:`.contact`     a contact realization: parts, kept springs and walls, what is lost
- :mod:`.meshes`      watertight triangle meshes: a pocketed slab, a drum, a height field, a pin
- :mod:`.exports`     writing and reading back device.toml, DXF (ezdxf) and STL (trimesh)
- :mod:`.heightfield` a plate whose height is the energy, and a ball rolling on it
- :mod:`.evaluation`  the design's own held-out evaluation on a realized device file
- :mod:`.drawing`     the parts at three positions, and Fig. 14
"""
