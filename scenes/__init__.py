"""Scene definitions and procedural texture/terrain generators (seeded; nothing downloaded)."""
