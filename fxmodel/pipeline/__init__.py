"""The assembled pipelines: the pixel pipeline, the engine from the triangle, their presets and baked lighting."""
