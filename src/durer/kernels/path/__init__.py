"""The path tracer's kernels.

- wavefront.py: a whole bounce of every live path (trace, shade, shadow ray, next ray) in one kernel on the
  one-level BVH; bounce.py: one bounce's shading for the other accelerators (the wavefront is traced first)
- bsdf.py, microfacet.py: BSDF evaluation, sampling and pdfs; Fresnel and GGX
- emitters.py: light sampling and the pdfs of emitters hit by BSDF-sampled rays; envmap.py: environment maps
  (bilinear lookup, sampling by two bisections, pdf)
- warps.py: local frames, square-to-sphere warps, MIS weights
- surface.py: hit points, normals and materials from hit records
- qmc.py: the hashed random stream and Owen-scrambled Sobol pairs
"""
