// Butcher tableaux of the explicit Runge-Kutta methods of the lockstep engine (flow_map.cpp) and of the fused step
// the SDK compiles into plugins (sdk.hpp, gb_advance_request): one definition, so both give the same numbers. Public
// because plugins include it through the SDK; not part of the C ABI. Sparse compile-time rows so that a stage state
// x + h sum_j a_ij k_j is one vectorisable pass over the block with the zero coefficients left out. Sources: Dormand &
// Prince 1980 (dopri5), Fehlberg 1968 as in Boost.Odeint's runge_kutta_fehlberg78 (rkf78), Hairer, Norsett & Wanner,
// Solving ODEs I, and their DOP853 code (dop853), Kutta 1901 (rk4), Runge 1895 (midpoint), Bogacki & Shampine 1989
// (bs32); the last two serve the tensor-line integrator only.
#ifndef GEOBARRIER_RK_TABLEAUX_HPP
#define GEOBARRIER_RK_TABLEAUX_HPP

#include <cmath>

// The Runge-Kutta pieces below and the SDK's fused step must be inlined into their lane loops, or the loops do not
// vectorise.
#if defined(__GNUC__)
#define GEOBARRIER_ALWAYS_INLINE inline __attribute__((always_inline))
#else
#define GEOBARRIER_ALWAYS_INLINE inline
#endif

namespace geobarrier::detail {

struct RkTerm {
    int stage;
    double weight;
};
// sum over the first `count` terms of weight * k[stage].
struct RkRow {
    int count;
    RkTerm terms[13];
};

// a * b + c with one rounding where the target has fused multiply-add instructions (then it is one instruction), else
// a * b + c. The builds use -ffp-contract=off, so the compiler never fuses on its own; the Runge-Kutta sums fuse
// explicitly through here: a dop853 stage costs half the arithmetic instructions, and the core's kernel and a
// plugin's fused step built with the same flags still round alike.
GEOBARRIER_ALWAYS_INLINE double mul_add(double a, double b, double c) {
#if defined(__FMA__) || defined(__aarch64__)
    return std::fma(a, b, c);
#else
    return a * b + c;
#endif
}

// sum over the row's terms of weight * value(stage), in term order, as a chain of mul_add (the embedded error
// estimates of flow_map.cpp; stage and step states use row_step below). Rows are compile-time constants, so after
// inlining the loop unrolls with the zero coefficients already left out.
template <class Value> GEOBARRIER_ALWAYS_INLINE double row_sum(const RkRow &row, Value value) {
    double s = row.terms[0].weight * value(row.terms[0].stage);
#pragma GCC unroll 16
    for (int t = 1; t < row.count; ++t) s = mul_add(row.terms[t].weight, value(row.terms[t].stage), s);
    return s;
}

// x + h sum over the row's terms of weight * value(stage): a chain of mul_add from x with the weights scaled by h (one
// instruction per term where the CPU has FMA; x + h row_sum(...) would cost one more per component and stage, 13% of
// a dop853 step). Rounding errors are then relative to x rather than to the increment: a few ulps of x per step, far
// below any tolerance the engine accepts (1e-14 relative). The stage states and new states of the core's kernel and
// of the SDK's fused step all go through here.
template <class Value> GEOBARRIER_ALWAYS_INLINE double row_step(const RkRow &row, double h, double x, Value value) {
    double s = x;
#pragma GCC unroll 16
    for (int t = 0; t < row.count; ++t) s = mul_add(h * row.terms[t].weight, value(row.terms[t].stage), s);
    return s;
}

// How a tableau estimates its local error: none (fixed step only), one embedded row e (err = h sum e_i k_i), or
// DOP853's pair of a 5th- and a 3rd-order estimate combined as err5^2 / sqrt(err5^2 + 0.01 err3^2) (Hairer's dop853.f,
// an O(h^8) estimate).
enum class RkError { none, embedded, dop853 };

struct Rk4Tableau {
    static constexpr const char *name = "rk4";
    static constexpr int stages = 4, order = 4, error_order = 0;
    static constexpr bool fsal = false;
    static constexpr RkError error = RkError::none;
    static constexpr double c[stages] = {0.0, 0.5, 0.5, 1.0};
    static constexpr RkRow a[stages] = {{0, {}}, {1, {{0, 0.5}}}, {1, {{1, 0.5}}}, {1, {{2, 1.0}}}};
    static constexpr RkRow b = {4, {{0, 1.0 / 6}, {1, 1.0 / 3}, {2, 1.0 / 3}, {3, 1.0 / 6}}};
    static constexpr RkRow e = {0, {}}, e3 = {0, {}};
};

// The explicit midpoint rule (Runge's second-order method), fixed steps only: the tensor-line integrator's cheapest
// method (tensor_lines.cpp), for fields that are only piecewise bilinear, where higher orders buy little.
struct MidpointTableau {
    static constexpr const char *name = "midpoint";
    static constexpr int stages = 2, order = 2, error_order = 0;
    static constexpr bool fsal = false;
    static constexpr RkError error = RkError::none;
    static constexpr double c[stages] = {0.0, 0.5};
    static constexpr RkRow a[stages] = {{0, {}}, {1, {{0, 0.5}}}};
    static constexpr RkRow b = {1, {{1, 1.0}}};
    static constexpr RkRow e = {0, {}}, e3 = {0, {}};
};

// Bogacki & Shampine 3(2), first same as last (stage 3 at the new state, a[3] = b): 3 evaluations per accepted step.
// Bogacki & Shampine, Appl. Math. Lett. 2 (1989) 321-325.
struct Bs32Tableau {
    static constexpr const char *name = "bs32";
    static constexpr int stages = 4, order = 3, error_order = 2;
    static constexpr bool fsal = true;
    static constexpr RkError error = RkError::embedded;
    static constexpr double c[stages] = {0.0, 0.5, 0.75, 1.0};
    static constexpr RkRow a[stages] = {
        {0, {}}, {1, {{0, 0.5}}}, {1, {{1, 0.75}}}, {3, {{0, 2.0 / 9}, {1, 1.0 / 3}, {2, 4.0 / 9}}}};
    static constexpr RkRow b = a[3];
    // b - b_hat (b_hat: the 2nd-order weights 7/24, 1/4, 1/3, 1/8).
    static constexpr RkRow e = {
        4, {{0, 2.0 / 9 - 7.0 / 24}, {1, 1.0 / 3 - 1.0 / 4}, {2, 4.0 / 9 - 1.0 / 3}, {3, -1.0 / 8}}};
    static constexpr RkRow e3 = {0, {}};
};

// Dormand-Prince 5(4), first same as last: stage 6 is evaluated at the new state (a[6] = b), so an accepted step
// costs 6 evaluations.
struct Dopri5Tableau {
    static constexpr const char *name = "dopri5";
    static constexpr int stages = 7, order = 5, error_order = 4;
    static constexpr bool fsal = true;
    static constexpr RkError error = RkError::embedded;
    static constexpr double c[stages] = {0.0, 0.2, 0.3, 0.8, 8.0 / 9, 1.0, 1.0};
    static constexpr RkRow a[stages] = {
        {0, {}},
        {1, {{0, 0.2}}},
        {2, {{0, 3.0 / 40}, {1, 9.0 / 40}}},
        {3, {{0, 44.0 / 45}, {1, -56.0 / 15}, {2, 32.0 / 9}}},
        {4, {{0, 19372.0 / 6561}, {1, -25360.0 / 2187}, {2, 64448.0 / 6561}, {3, -212.0 / 729}}},
        {5, {{0, 9017.0 / 3168}, {1, -355.0 / 33}, {2, 46732.0 / 5247}, {3, 49.0 / 176}, {4, -5103.0 / 18656}}},
        {5, {{0, 35.0 / 384}, {2, 500.0 / 1113}, {3, 125.0 / 192}, {4, -2187.0 / 6784}, {5, 11.0 / 84}}},
    };
    static constexpr RkRow b = a[6];
    // b - b_hat (b_hat: the 4th-order weights 5179/57600, 0, 7571/16695, 393/640, -92097/339200, 187/2100, 1/40).
    static constexpr RkRow e = {6,
                                {{0, 35.0 / 384 - 5179.0 / 57600},
                                 {2, 500.0 / 1113 - 7571.0 / 16695},
                                 {3, 125.0 / 192 - 393.0 / 640},
                                 {4, -2187.0 / 6784 + 92097.0 / 339200},
                                 {5, 11.0 / 84 - 187.0 / 2100},
                                 {6, -1.0 / 40}}};
    static constexpr RkRow e3 = {0, {}};
};

// Fehlberg 7(8), 13 stages, propagating the 8th-order solution (as Boost.Odeint's runge_kutta_fehlberg78).
struct Rkf78Tableau {
    static constexpr const char *name = "rkf78";
    static constexpr int stages = 13, order = 8, error_order = 7;
    static constexpr bool fsal = false;
    static constexpr RkError error = RkError::embedded;
    static constexpr double c[stages] = {0.0,     2.0 / 27, 1.0 / 9, 1.0 / 6, 5.0 / 12, 0.5, 5.0 / 6,
                                         1.0 / 6, 2.0 / 3,  1.0 / 3, 1.0,     0.0,      1.0};
    static constexpr RkRow a[stages] = {
        {0, {}},
        {1, {{0, 2.0 / 27}}},
        {2, {{0, 1.0 / 36}, {1, 1.0 / 12}}},
        {2, {{0, 1.0 / 24}, {2, 1.0 / 8}}},
        {3, {{0, 5.0 / 12}, {2, -25.0 / 16}, {3, 25.0 / 16}}},
        {3, {{0, 1.0 / 20}, {3, 1.0 / 4}, {4, 1.0 / 5}}},
        {4, {{0, -25.0 / 108}, {3, 125.0 / 108}, {4, -65.0 / 27}, {5, 125.0 / 54}}},
        {4, {{0, 31.0 / 300}, {4, 61.0 / 225}, {5, -2.0 / 9}, {6, 13.0 / 900}}},
        {6, {{0, 2.0}, {3, -53.0 / 6}, {4, 704.0 / 45}, {5, -107.0 / 9}, {6, 67.0 / 90}, {7, 3.0}}},
        {7,
         {{0, -91.0 / 108},
          {3, 23.0 / 108},
          {4, -976.0 / 135},
          {5, 311.0 / 54},
          {6, -19.0 / 60},
          {7, 17.0 / 6},
          {8, -1.0 / 12}}},
        {8,
         {{0, 2383.0 / 4100},
          {3, -341.0 / 164},
          {4, 4496.0 / 1025},
          {5, -301.0 / 82},
          {6, 2133.0 / 4100},
          {7, 45.0 / 82},
          {8, 45.0 / 164},
          {9, 18.0 / 41}}},
        {6, {{0, 3.0 / 205}, {5, -6.0 / 41}, {6, -3.0 / 205}, {7, -3.0 / 41}, {8, 3.0 / 41}, {9, 6.0 / 41}}},
        {9,
         {{0, -1777.0 / 4100},
          {3, -341.0 / 164},
          {4, 4496.0 / 1025},
          {5, -289.0 / 82},
          {6, 2193.0 / 4100},
          {7, 51.0 / 82},
          {8, 33.0 / 164},
          {9, 12.0 / 41},
          {11, 1.0}}},
    };
    static constexpr RkRow b = {7,
                                {{5, 34.0 / 105},
                                 {6, 9.0 / 35},
                                 {7, 9.0 / 35},
                                 {8, 9.0 / 280},
                                 {9, 9.0 / 280},
                                 {11, 41.0 / 840},
                                 {12, 41.0 / 840}}};
    static constexpr RkRow e = {4, {{0, -41.0 / 840}, {10, -41.0 / 840}, {11, 41.0 / 840}, {12, 41.0 / 840}}};
    static constexpr RkRow e3 = {0, {}};
};

// Dormand & Prince's 8th-order method DOP853 (12 stages; the 13th evaluation of dop853.f is the derivative at the new
// state, the next step's stage 0). Coefficients as printed in Hairer's dop853.f.
struct Dop853Tableau {
    static constexpr const char *name = "dop853";
    static constexpr int stages = 12, order = 8, error_order = 7;
    static constexpr bool fsal = false;
    static constexpr RkError error = RkError::dop853;
    static constexpr double c[stages] = {0.0,
                                         0.526001519587677318785587544488e-01,
                                         0.789002279381515978178381316732e-01,
                                         0.118350341907227396726757197510,
                                         0.281649658092772603273242802490,
                                         0.333333333333333333333333333333,
                                         0.25,
                                         0.307692307692307692307692307692,
                                         0.651282051282051282051282051282,
                                         0.6,
                                         0.857142857142857142857142857142,
                                         1.0};
    static constexpr RkRow a[stages] = {
        {0, {}},
        {1, {{0, 5.26001519587677318785587544488e-2}}},
        {2, {{0, 1.97250569845378994544595329183e-2}, {1, 5.91751709536136983633785987549e-2}}},
        {2, {{0, 2.95875854768068491816892993775e-2}, {2, 8.87627564304205475450678981324e-2}}},
        {3,
         {{0, 2.41365134159266685502369798665e-1},
          {2, -8.84549479328286085344864962717e-1},
          {3, 9.24834003261792003115737966543e-1}}},
        {3,
         {{0, 3.7037037037037037037037037037e-2},
          {3, 1.70828608729473871279604482173e-1},
          {4, 1.25467687566822425016691814123e-1}}},
        {4,
         {{0, 3.7109375e-2},
          {3, 1.70252211019544039314978060272e-1},
          {4, 6.02165389804559606850219397283e-2},
          {5, -1.7578125e-2}}},
        {5,
         {{0, 3.70920001185047927108779319836e-2},
          {3, 1.70383925712239993810214054705e-1},
          {4, 1.07262030446373284651809199168e-1},
          {5, -1.53194377486244017527936158236e-2},
          {6, 8.27378916381402288758473766002e-3}}},
        {6,
         {{0, 6.24110958716075717114429577812e-1},
          {3, -3.36089262944694129406857109825},
          {4, -8.68219346841726006818189891453e-1},
          {5, 2.75920996994467083049415600797e1},
          {6, 2.01540675504778934086186788979e1},
          {7, -4.34898841810699588477366255144e1}}},
        {7,
         {{0, 4.77662536438264365890433908527e-1},
          {3, -2.48811461997166764192642586468},
          {4, -5.90290826836842996371446475743e-1},
          {5, 2.12300514481811942347288949897e1},
          {6, 1.52792336328824235832596922938e1},
          {7, -3.32882109689848629194453265587e1},
          {8, -2.03312017085086261358222928593e-2}}},
        {8,
         {{0, -9.3714243008598732571704021658e-1},
          {3, 5.18637242884406370830023853209},
          {4, 1.09143734899672957818500254654},
          {5, -8.14978701074692612513997267357},
          {6, -1.85200656599969598641566180701e1},
          {7, 2.27394870993505042818970056734e1},
          {8, 2.49360555267965238987089396762},
          {9, -3.0467644718982195003823669022}}},
        {9,
         {{0, 2.27331014751653820792359768449},
          {3, -1.05344954667372501984066689879e1},
          {4, -2.00087205822486249909675718444},
          {5, -1.79589318631187989172765950534e1},
          {6, 2.79488845294199600508499808837e1},
          {7, -2.85899827713502369474065508674},
          {8, -8.87285693353062954433549289258},
          {9, 1.23605671757943030647266201528e1},
          {10, 6.43392746015763530355970484046e-1}}},
    };
    static constexpr RkRow b = {8,
                                {{0, 5.42937341165687622380535766363e-2},
                                 {5, 4.45031289275240888144113950566},
                                 {6, 1.89151789931450038304281599044},
                                 {7, -5.8012039600105847814672114227},
                                 {8, 3.1116436695781989440891606237e-1},
                                 {9, -1.52160949662516078556178806805e-1},
                                 {10, 2.01365400804030348374776537501e-1},
                                 {11, 4.47106157277725905176885569043e-2}}};
    // The 5th-order error row (er1..er12 of dop853.f) and the 3rd-order one (b - bhh).
    static constexpr RkRow e = {8,
                                {{0, 0.1312004499419488073250102996e-1},
                                 {5, -0.1225156446376204440720569753e1},
                                 {6, -0.4957589496572501915214079952},
                                 {7, 0.1664377182454986536961530415e1},
                                 {8, -0.3503288487499736816886487290},
                                 {9, 0.3341791187130174790297318841},
                                 {10, 0.8192320648511571246570742613e-1},
                                 {11, -0.2235530786388629525884427845e-1}}};
    static constexpr RkRow e3 = {8,
                                 {{0, 5.42937341165687622380535766363e-2 - 0.244094488188976377952755905512},
                                  {5, 4.45031289275240888144113950566},
                                  {6, 1.89151789931450038304281599044},
                                  {7, -5.8012039600105847814672114227},
                                  {8, 3.1116436695781989440891606237e-1 - 0.733846688281611857341361741547},
                                  {9, -1.52160949662516078556178806805e-1},
                                  {10, 2.01365400804030348374776537501e-1},
                                  {11, 4.47106157277725905176885569043e-2 - 0.220588235294117647058823529412e-1}}};
};

// The checked fixed steps' error test (flow_map.cpp, and the SDK's fused step through gb_advance_request.lane_error):
// per lane, the largest |sum_j e_j k_j| over the state components, the embedded error estimate of a step over h
// (for DOP853 its 5th-order estimate alone, er1..er12 of dop853.f). The core multiplies by |h| and divides by the
// lane's scale atol + rtol max(|x|, |x_new|) over the components (checked_lane_scale in flow_map.cpp). Deliberately
// lean, because it runs inside the fused step on every lane and step: about 9 multiply-adds per state component,
// no square root (which may set errno, and keeps compilers from vectorising the lane loop unless built with
// -fno-math-errno; plugins choose their own flags) and no division. Hairer's combination with the 3rd-order estimate
// would make the estimate O(h^8) rather than O(h^6); without it the test is more cautious on hard systems, which is
// the side to err on. The core's kernel and the fused step both call this, so they take the same decisions.
template <class Tab, unsigned Components, class Value>
GEOBARRIER_ALWAYS_INLINE double lane_error_estimate(Value value) {
    double worst = 0.0;
#pragma GCC unroll 16
    for (unsigned i = 0; i < Components; ++i) {
        const double e = std::fabs(row_sum(Tab::e, [&](int j) { return value(j, i); }));
        worst = worst < e ? e : worst; // NaN: the core screens the new state
    }
    return worst;
}

} // namespace geobarrier::detail

#endif // GEOBARRIER_RK_TABLEAUX_HPP
