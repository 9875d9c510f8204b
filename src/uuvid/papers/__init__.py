"""Reproductions of the papers' printed numbers and studies, written as clients of the library:
McLean 1991 (``mclean1991``, ``mclean1991_identification``), Laidani et al. (``laidani``,
``laidani_identification``), Caccia et al. 2000 (``caccia2000``) and the thruster-loop study."""
