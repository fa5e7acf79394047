"""erf and erfc ported from fdlibm (FreeBSD msun / openlibm): s_erf.c, with numerics.exponential.exp.

erfc(+inf) = 0, erfc(-inf) = 2, erf(+-inf) = +-1.

Copyright (C) 1993 by Sun Microsystems, Inc. All rights reserved.
Developed at SunPro, a Sun Microsystems, Inc. business.
Permission to use, copy, modify, and distribute this software is freely granted, provided that this notice is
preserved.
"""

from math import copysign, fabs, inf

from numerics._bits import clear_low_word, from_words
from numerics.exponential import exp

_ERX = 8.45062911510467529297e-01  # 0x3FEB0AC1, 0x60000000: (float)0.84506291151
# erf on [0, 0.84375]
_EFX = 1.28379167095512586316e-01  # 0x3FC06EBA, 0x8214DB69
_EFX8 = 1.02703333676410069053e00  # 0x3FF06EBA, 0x8214DB69
_PP0 = 1.28379167095512558561e-01  # 0x3FC06EBA, 0x8214DB68
_PP1 = -3.25042107247001499370e-01  # 0xBFD4CD7D, 0x691CB913
_PP2 = -2.84817495755985104766e-02  # 0xBF9D2A51, 0xDBD7194F
_PP3 = -5.77027029648944159157e-03  # 0xBF77A291, 0x236668E4
_PP4 = -2.37630166566501626084e-05  # 0xBEF8EAD6, 0x120016AC
_QQ1 = 3.97917223959155352819e-01  # 0x3FD97779, 0xCDDADC09
_QQ2 = 6.50222499887672944485e-02  # 0x3FB0A54C, 0x5536CEBA
_QQ3 = 5.08130628187576562776e-03  # 0x3F74D022, 0xC4D36B0F
_QQ4 = 1.32494738004321644526e-04  # 0x3F215DC9, 0x221C1A10
_QQ5 = -3.96022827877536812320e-06  # 0xBED09C43, 0x42A26120
# erf in [0.84375, 1.25]
_PA0 = -2.36211856075265944077e-03  # 0xBF6359B8, 0xBEF77538
_PA1 = 4.14856118683748331666e-01  # 0x3FDA8D00, 0xAD92B34D
_PA2 = -3.72207876035701323847e-01  # 0xBFD7D240, 0xFBB8C3F1
_PA3 = 3.18346619901161753674e-01  # 0x3FD45FCA, 0x805120E4
_PA4 = -1.10894694282396677476e-01  # 0xBFBC6398, 0x3D3E28EC
_PA5 = 3.54783043256182359371e-02  # 0x3FA22A36, 0x599795EB
_PA6 = -2.16637559486879084300e-03  # 0xBF61BF38, 0x0A96073F
_QA1 = 1.06420880400844228286e-01  # 0x3FBB3E66, 0x18EEE323
_QA2 = 5.40397917702171048937e-01  # 0x3FE14AF0, 0x92EB6F33
_QA3 = 7.18286544141962662868e-02  # 0x3FB2635C, 0xD99FE9A7
_QA4 = 1.26171219808761642112e-01  # 0x3FC02660, 0xE763351F
_QA5 = 1.36370839120290507362e-02  # 0x3F8BEDC2, 0x6B51DD1C
_QA6 = 1.19844998467991074170e-02  # 0x3F888B54, 0x5735151D
# erfc in [1.25, 1/0.35]
_RA0 = -9.86494403484714822705e-03  # 0xBF843412, 0x600D6435
_RA1 = -6.93858572707181764372e-01  # 0xBFE63416, 0xE4BA7360
_RA2 = -1.05586262253232909814e01  # 0xC0251E04, 0x41B0E726
_RA3 = -6.23753324503260060396e01  # 0xC04F300A, 0xE4CBA38D
_RA4 = -1.62396669462573470355e02  # 0xC0644CB1, 0x84282266
_RA5 = -1.84605092906711035994e02  # 0xC067135C, 0xEBCCABB2
_RA6 = -8.12874355063065934246e01  # 0xC0545265, 0x57E4D2F2
_RA7 = -9.81432934416914548592e00  # 0xC023A0EF, 0xC69AC25C
_SA1 = 1.96512716674392571292e01  # 0x4033A6B9, 0xBD707687
_SA2 = 1.37657754143519042600e02  # 0x4061350C, 0x526AE721
_SA3 = 4.34565877475229228821e02  # 0x407B290D, 0xD58A1A71
_SA4 = 6.45387271733267880336e02  # 0x40842B19, 0x21EC2868
_SA5 = 4.29008140027567833386e02  # 0x407AD021, 0x57700314
_SA6 = 1.08635005541779435134e02  # 0x405B28A3, 0xEE48AE2C
_SA7 = 6.57024977031928170135e00  # 0x401A47EF, 0x8E484A93
_SA8 = -6.04244152148580987438e-02  # 0xBFAEEFF2, 0xEE749A62
# erfc in [1/0.35, 28]
_RB0 = -9.86494292470009928597e-03  # 0xBF843412, 0x39E86F4A
_RB1 = -7.99283237680523006574e-01  # 0xBFE993BA, 0x70C285DE
_RB2 = -1.77579549177547519889e01  # 0xC031C209, 0x555F995A
_RB3 = -1.60636384855821916062e02  # 0xC064145D, 0x43C5ED98
_RB4 = -6.37566443368389627722e02  # 0xC083EC88, 0x1375F228
_RB5 = -1.02509513161107724954e03  # 0xC0900461, 0x6A2E5992
_RB6 = -4.83519191608651397019e02  # 0xC07E384E, 0x9BDC383F
_SB1 = 3.03380607434824582924e01  # 0x403E568B, 0x261D5190
_SB2 = 3.25792512996573918826e02  # 0x40745CAE, 0x221B9F0A
_SB3 = 1.53672958608443695994e03  # 0x409802EB, 0x189D5118
_SB4 = 3.19985821950859553908e03  # 0x40A8FFB7, 0x688C246A
_SB5 = 2.55305040643316442583e03  # 0x40A3F219, 0xCEDF3BE6
_SB6 = 4.74528541206955367215e02  # 0x407DA874, 0xE79FE763
_SB7 = -2.24409524465858183362e01  # 0xC03670E2, 0x42712D62

_TWO_M28 = from_words(0x3E300000, 0)
_TWO_M56 = from_words(0x3C700000, 0)
_TWO_M1015 = from_words(0x00800000, 0)
_ERF_SPLIT = from_words(0x4006DB6E, 0)  # ~1/0.35 in erf (ix < 0x4006DB6E)
_ERFC_SPLIT = from_words(0x4006DB6D, 0)  # ~1/0.35 in erfc (ix < 0x4006DB6D)


def _small_ratio(z: float) -> float:
    """r(z)/s(z) for erf(x) = x + x*r/s, z = x*x, |x| < 0.84375."""
    r = _PP0 + z * (_PP1 + z * (_PP2 + z * (_PP3 + z * _PP4)))
    s = 1.0 + z * (_QQ1 + z * (_QQ2 + z * (_QQ3 + z * (_QQ4 + z * _QQ5))))
    return r / s


def _mid_ratio(s: float) -> float:
    """P(s)/Q(s) for erf(1 + s) = erx + P/Q, 0.84375 <= 1 + s < 1.25."""
    p = _PA0 + s * (_PA1 + s * (_PA2 + s * (_PA3 + s * (_PA4 + s * (_PA5 + s * _PA6)))))
    q = 1.0 + s * (_QA1 + s * (_QA2 + s * (_QA3 + s * (_QA4 + s * (_QA5 + s * _QA6)))))
    return p / q


def _tail(ax: float, split: float) -> float:
    """erfc(ax) for 1.25 <= ax < 28: exp(-z*z - 0.5625)*exp((z - ax)*(z + ax) + R/S)/ax."""
    s = 1.0 / (ax * ax)
    if ax < split:
        r = _RA0 + s * (_RA1 + s * (_RA2 + s * (_RA3 + s * (_RA4 + s * (_RA5 + s * (_RA6 + s * _RA7))))))
        q = 1.0 + s * (_SA1 + s * (_SA2 + s * (_SA3 + s * (_SA4 + s * (_SA5 + s * (_SA6 + s * (_SA7 + s * _SA8)))))))
    else:
        r = _RB0 + s * (_RB1 + s * (_RB2 + s * (_RB3 + s * (_RB4 + s * (_RB5 + s * _RB6)))))
        q = 1.0 + s * (_SB1 + s * (_SB2 + s * (_SB3 + s * (_SB4 + s * (_SB5 + s * (_SB6 + s * _SB7))))))
    z = clear_low_word(ax)
    return exp(-z * z - 0.5625) * exp((z - ax) * (z + ax) + r / q) / ax


def erf(x: float) -> float:
    """Error function (s_erf.c); erf(+-inf) = +-1."""
    ax = fabs(x)
    if not ax < inf:
        return x if x != x else copysign(1.0, x)
    if ax < 0.84375:
        if ax < _TWO_M28:
            if ax < _TWO_M1015:
                return 0.125 * (8.0 * x + _EFX8 * x)  # avoid underflow
            return x + _EFX * x
        return x + x * _small_ratio(x * x)
    if ax < 1.25:
        pq = _mid_ratio(ax - 1.0)
        return _ERX + pq if x >= 0.0 else -_ERX - pq
    if ax >= 6.0:
        return copysign(1.0, x)
    r = _tail(ax, _ERF_SPLIT)
    return 1.0 - r if x >= 0.0 else r - 1.0


def erfc(x: float) -> float:
    """Complementary error function 1 - erf(x) (s_erf.c); erfc(+inf) = 0, erfc(-inf) = 2."""
    ax = fabs(x)
    if not ax < inf:
        if x != x:
            return x
        return 0.0 if x > 0.0 else 2.0
    if ax < 0.84375:
        if ax < _TWO_M56:
            return 1.0 - x
        y = _small_ratio(x * x)
        if x < 0.25:
            return 1.0 - (x + x * y)
        return 0.5 - (x * y + (x - 0.5))
    if ax < 1.25:
        pq = _mid_ratio(ax - 1.0)
        return (1.0 - _ERX) - pq if x >= 0.0 else 1.0 + (_ERX + pq)
    if ax < 28.0:
        if x <= -6.0:
            return 2.0
        r = _tail(ax, _ERFC_SPLIT)
        return r if x > 0.0 else 2.0 - r
    return 0.0 if x > 0.0 else 2.0
