"""Motion capture onto a puppet: BVH files read and posed (bvh), projected to the picture and
scaled (project), pins mapped to joints without a hand-written map (mapping), feet held
where they touch the ground (contact), the scene's animation keys written (retarget), and
``puppet retarget`` (command).

It sits one layer below ``app``, ``video`` and ``batch`` (the app's File > Retarget motion
uses it): it reads scenes through ``puppet.api`` and thins keys with ``puppet.anim.keys``. It is a package of
its own rather than a part of ``video``: nothing is tracked in a picture here, and the BVH
reader has no use for video's SIFT, clips or encoders.
"""
