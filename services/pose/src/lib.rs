//! The pose stage: a 16-joint skeleton from each depth frame by geodesic distances
