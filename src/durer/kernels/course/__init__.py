"""The MIT 6.837 course's own algorithms: the uniform grid with 3D-DDA (grid.py) and Perlin's improved noise
for the solid textures (noise.py)."""
