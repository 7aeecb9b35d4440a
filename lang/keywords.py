"""POV-Ray 3.7's reserved words, sorted into the classes the grammar needs.

The grammar only distinguishes words that change the *shape* of the text: value keywords
(constants, built-in functions, colour constructors and components) and the rest. Everything
else is one KEYWORD terminal; which keyword belongs where is the schema's business.
"""

from __future__ import annotations

# Built-in value keywords: used as operands in expressions.
CONSTANTS = frozenset(
    """
    x y z t u v pi tau clock clock_delta clock_on final_clock final_frame frame_number
    initial_clock initial_frame image_width image_height true false on off yes no version
    now input_file_name
    """.split()
)

# Built-in functions: always called as `name(args)`.
FUNCTIONS = frozenset(
    """
    abs acos acosh asc asin asinh atan atan2 atanh bitwise_and bitwise_or bitwise_xor ceil
    chr concat cos cosh datetime defined degrees dimension_size dimensions div exp
    file_exists floor inside int ln log max max_extent min min_extent mod pow prod radians
    rand seed select sin sinh sqr sqrt str strcmp strlen strlwr strupr substr sum tan tanh
    trace val vaxis_rotate vcross vdot vlength vnormalize vrotate vstr vturbulence
    """.split()
)

COLOR_TYPES = frozenset("rgb rgbf rgbt rgbft srgb srgbf srgbt srgbft".split())
COLOR_WORDS = frozenset(("color", "colour"))
# Colour components: the old `color red 1 green .5` form and `.red` member access.
COMPONENTS = frozenset("red green blue filter transmit gray grey".split())

# Directive words (written with a leading '#').
DIRECTIVES = frozenset(
    """
    include declare local undef if elseif else end ifdef ifndef switch case range break
    while for macro version debug warning error default fopen fclose read write render
    statistics
    """.split()
)

# Every other reserved word: block heads and item keywords.
ITEM_WORDS = frozenset(
    """
    aa_level aa_threshold absorption accuracy adaptive adc_bailout agate agate_turb albedo
    all all_intersections alpha altitude always_sample ambient ambient_light angle
    anisotropy aoi aperture append arc_angle area_illumination area_light array ascii
    assumed_gamma autostop average b_spline background bezier_spline bicubic_patch
    black_hole blob blur_samples bokeh bounded_by box boxed bozo brick brick_size
    brightness brilliance bump_map bump_size bumps camera caustics cells charset checker
    circular clipped_by collect color_map colour_map component composite confidence
    cone conic_sweep default conserve_energy contained_by control0 control1 coords count
    crackle crand
    cube cubic cubic_spline cubic_wave cutaway_textures cylinder cylindrical density
    density_file density_map dents df3 difference diffuse direction disc dispersion
    dispersion_samples dist_exp distance double_illuminate eccentricity emission
    error_bound evaluate exponent exterior expand_thresholds extinction face_indices
    facets fade_color fade_colour fade_distance fade_power falloff falloff_angle
    finish fisheye flatness flip focal_blur focal_point fog fog_alt fog_offset fog_type
    form frequency fresnel function gather gif global_lights global_settings gradient
    granite gray_threshold height_field hexagon hf_gray_16 hierarchy hollow hypercomplex
    image_map image_pattern importance interior interior_texture internal interpolate
    intersection intervals inverse ior irid irid_wavelength isosurface jitter jpeg
    julia julia_fractal lambda lathe leopard light_group light_source linear_spline
    linear_sweep load_file location look_at looks_like low_error_factor magnet
    major_radius mandel map_type marble material material_map matrix max_gradient
    max_intersections max_iteration max_sample max_trace max_trace_level maximum_reuse
    media media_attenuation media_interaction merge mesh mesh2 mesh_camera metallic method
    minimum_reuse mixed mm_per_unit mortar natural_spline nearest_count no no_bump_scale
    no_image no_radiosity no_reflection no_shadow noise_generator normal normal_indices
    normal_map normal_vectors number_of_waves object octaves offset omega omnimax once
    onion open optional orient orientation orthographic ovus panoramic parallel
    parametric pass_through pattern perspective pgm phase phong phong_size photons
    pigment pigment_map pigment_pattern planar plane png point_at poly poly_wave polygon
    polynomial pot pov ppm precision precompute premultiplied pretrace_end pretrace_start
    prism projected_through pwr quadratic_spline quadric quartic quaternion quick_color
    quick_colour quilted radial radiosity radius rainbow ramp_wave ratio reciprocal
    recursion_limit reflection reflection_exponent refraction repeat right ripples rotate
    roughness samples save_file scale scallop_wave scattering shadowless sine_wave sint16be
    sint16le sint32be sint32le sint8 size sky sky_sphere slice slope slope_map smooth
    smooth_triangle solid sor spacing specular sphere sphere_sweep spherical spiral
    spiral1 spiral2 spline split_union spotlight spotted square strength sturm
    subsurface superellipsoid sys target text texture texture_list texture_map tga
    thickness threshold tiff tightness tile2 tiles tiling tolerance toroidal torus
    trace_level transform translate translucency triangle triangle_wave triangular ttf
    turb_depth turbulence type union u_steps uint16be uint16le uint8 ultra_wide_angle up
    use_alpha use_color use_colour use_index utf8 uv_indices uv_mapping uv_vectors
    v_steps variance vertex_vectors warp water_level waves width wood wrinkles xyz
    exr hdr read write metric lemon inside_vector
    nurbs subdivision u_degree v_degree control_points weights u_knots v_knots knots
    crease_edges crease_sharpness corner_vertices catmull_clark four_point patch_size
    max_patches
    """.split()
)
# strala's own item words that read as plain identifiers (users may have variables with these
# names): the evaluator takes them as keywords only inside the blocks whose schema lists them.
SOFT_WORDS = frozenset(
    "degree scheme levels boundary limit m chaikin midpoint loop bilinear sharp "
    "gauss_seidel progressive direct display gouraud flat".split()
)
# Words that are items but also directive names (read/write as #fopen modes) stay items.
ITEM_WORDS = ITEM_WORDS - CONSTANTS - FUNCTIONS - COLOR_TYPES - COLOR_WORDS - COMPONENTS

ALL_WORDS = CONSTANTS | FUNCTIONS | COLOR_TYPES | COLOR_WORDS | COMPONENTS | ITEM_WORDS
