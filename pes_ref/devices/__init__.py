"""Devices from part geometry: rigid polygons and their motions ([`.geometry`][pes_ref.devices.geometry]), the
configuration space and the paper's eq. (1) surface ([`.cspace`][pes_ref.devices.cspace]), and the two
devices of the paper, the ratchet ([`.ratchet`][pes_ref.devices.ratchet]) and the dart gun ([`.dartgun`][pes_ref.devices.dartgun])."""
