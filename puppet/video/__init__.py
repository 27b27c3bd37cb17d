"""Cartoon video deformation: a skeleton on the first frame, tracked with SIFT, each frame re-posed."""
