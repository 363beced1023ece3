"""Host software, not the golden model: scene files, meshes, bump maps and textures, the float front end and
references, rendering and random scenes."""
