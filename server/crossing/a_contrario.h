#ifndef WAYMARK_SERVER_CROSSING_A_CONTRARIO_H_
#define WAYMARK_SERVER_CROSSING_A_CONTRARIO_H_

// A chance-corrected acceptance rule for the epipolar verification (Moisan & Stival, "A
// probabilistic criterion to detect rigid point matches between two images and estimate the
// fundamental matrix", IJCV 2004: ORSA). Instead of an absolute number of inliers, which means
// different things for 100 and 2,000 keypoints or for 160x120 and 1280x960 images, a match set is
// judged by how often chance alone would produce one as consistent:
//
//   NFA(k) = tests * 3 * (n - 7) * C(n, k) * C(k, 7) * alpha_k^(k - 8)
//
// n tentative matches, k of them within e_k pixels of their epipolar line (e_k the k-th smallest
// residual), alpha_k = 2 e_k D / A the probability that a random point of an image of diagonal D
// and area A lies that close to a given line, C(k, 7) the 7-point samples that fix the geometry
// (up to 3 solutions), and `tests` the number of views verified for the query. The exponent is
// ORSA's k - 7 less one: the model comes back refitted to all its inliers by least squares (8
// parameters), which pulls every inlier's residual down. The expected
// number of views matched this well by chance is the minimum over k; below 1 (log10 < 0) the
// match is "meaningful", and one threshold holds across cameras and resolutions.

#include <vector>

#include <opencv2/core.hpp>

namespace waymark::crossing {

struct EpipolarEvidence {
  int inliers = 0;            // k at the minimum NFA (0: no geometry)
  double log10_nfa = 1e9;     // log10 of the minimum NFA (huge: no geometry)
  double residual_px = 0.0;   // e_k: the inliers' largest epipolar distance
};

// log10 of the minimum NFA over k for the residuals of n tentative matches (pixels, any order;
// non-finite residuals never count as inliers) in images of `image` size. Fewer than 8 matches:
// no evidence.
EpipolarEvidence AContrarioEvidence(std::vector<double> residuals_px, cv::Size image,
                                    double tests);

// The support the random-point model of AContrarioEvidence should use for matches at `points`:
// their bounding box, at least a quarter of `image` on each side. Chance matches of real images
// are not spread over the frame: they gather where the texture is (a tree, a poster, a window
// row), and a line then crosses a larger share of their region than of the frame.
cv::Size MatchSupport(const std::vector<cv::Point2f>& points, cv::Size image);

// Symmetric epipolar residuals (the larger of the two point-to-line distances, pixels) of pairs
// under F, with view = F * query (x_view^T F x_query = 0).
std::vector<double> EpipolarResiduals(const cv::Matx33d& f,
                                      const std::vector<cv::Point2f>& query_points,
                                      const std::vector<cv::Point2f>& view_points);

// log10 of the binomial coefficient C(n, k).
double Log10Binomial(int n, int k);

}  // namespace waymark::crossing

#endif  // WAYMARK_SERVER_CROSSING_A_CONTRARIO_H_
