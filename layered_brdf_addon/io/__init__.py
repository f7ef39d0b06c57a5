"""Files in and out, without Blender: staging outputs so that they appear whole or not at all (and an
interrupt leaves nothing), the image codecs, render sidecars (their schema and the one reader), and values
in messages.  The command line (``cli``) and the Blender layer (``blender``) both import it; it imports
neither.
"""
