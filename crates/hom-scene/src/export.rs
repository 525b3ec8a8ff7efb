//! OBJ export of world-space triangles. (Being written.)
