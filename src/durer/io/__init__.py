"""Reading scenes and meshes, writing images."""
