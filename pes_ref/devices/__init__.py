"""Devices from part geometry: rigid polygons and their motions (:mod:`.geometry`), the
configuration space and the paper's eq. (1) surface (:mod:`.cspace`), and the two
devices of the paper, the ratchet (:mod:`.ratchet`) and the dart gun (:mod:`.dartgun`)."""
